"""Parallel RLC fit of impedance spectroscopy: the coil of Table 2 at its three temperatures."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.analysis.spectroscopy import fit_parallel_rlc, fit_spectroscopy
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.drivers.hm8118 import FREQUENCIES_HZ
from ecds_lab.simulators.campaign import spectroscopy
from ecds_lab.simulators.config import LabConfig, Thermal
from ecds_lab.simulators.lab import SimulatedLab

#: Table 2: coil temperature (C), L_p (H), C_p (F), R_p (Ohm).
TABLE_2 = [(20.0, 61e-3, 62.5e-12, 92e3), (65.0, 60.4e-3, 47.46e-12, 212e3), (120.0, 58.4e-3, 47.53e-12, 984e3)]
SPECTRUM_HZ = [f for f in FREQUENCIES_HZ if f >= 100]


def _coil_at(row: tuple[float, float, float, float], seed: int) -> SimulatedLab:
    t, inductance, capacitance, resistance = row
    sensor = SensorConfig(inductance_h=inductance, capacitance_f=capacitance, parallel_resistance_ohm=resistance,
                          reference_temperature_c=t)
    return SimulatedLab(LabConfig(sensor=sensor, target_present=False, thermal=Thermal(ambient_c=t), seed=seed))


@pytest.mark.parametrize("row", TABLE_2, ids=["20C", "65C", "120C"])
def test_parallel_rlc_fit_recovers_table_2(row):
    t, inductance, capacitance, resistance = row
    data = spectroscopy(_coil_at(row, seed=int(t)), SPECTRUM_HZ)
    fit = fit_parallel_rlc(data.freq_hz, data.ls_h, data.rs_ohm)
    assert fit.inductance_h == pytest.approx(inductance, rel=0.02)
    assert fit.capacitance_f == pytest.approx(capacitance, rel=0.02)
    assert fit.parallel_resistance_ohm == pytest.approx(resistance, rel=0.02)
    assert fit.series_resistance_ohm == pytest.approx(SensorConfig().resistance_ohm, rel=0.02)
    assert fit.resonance_hz == pytest.approx(1 / (2 * np.pi * np.sqrt(inductance * capacitance)), rel=0.02)
    assert fit.rms_ppm < 2 * LabConfig().noise.bridge_relative["slow"] * 1e6
    assert fit.stderr["parallel_resistance_ohm"] < 0.01 * resistance


def test_one_fit_per_segment_with_its_temperature():
    parts = [spectroscopy(_coil_at(row, seed=1), SPECTRUM_HZ) for row in TABLE_2]
    fits = fit_spectroscopy(Measurements.concatenate(parts))
    assert [round(f.t_coil_c) for f in fits] == [20, 65, 120]
    assert [f.capacitance_f for f in fits] == pytest.approx([r[2] for r in TABLE_2], rel=0.02)
    assert set(fits[0].as_dict()) >= {"inductance_h", "capacitance_f", "parallel_resistance_ohm", "resonance_hz"}


def test_too_few_frequencies_is_an_error():
    with pytest.raises(ValueError, match="four"):
        fit_parallel_rlc(np.array([1e3, 2e3, 3e3]), np.ones(3), np.ones(3))
