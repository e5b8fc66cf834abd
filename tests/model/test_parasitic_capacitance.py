"""The former's moisture law recovers moisture that dries toward a sorption equilibrium.

The truth is written another way than the library's law: sorbed water relaxing toward a Henry
isotherm at the pores' relative humidity (saturation pressure from the Magnus formula), with an
Arrhenius drying rate, integrated in 5 s steps; its extra capacitance is put in parallel with the
faithful simulated lab's coil (its own moisture off) during coil heating in the thermal box.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.analysis.fitting import fit
from ecds_lab.data.measurements import Measurements
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

MOIST_DC_F = 15e-12  # Table 2: 62.5 pF moist vs 47.5 pF dry


def saturation_pressure_pa(t_c: np.ndarray | float) -> np.ndarray:
    """Magnus formula for water over a flat surface."""
    return 610.94 * np.exp(17.625 * np.asarray(t_c) / (np.asarray(t_c) + 243.04))


def sorbed_moisture(time_s: np.ndarray, t_c: np.ndarray, rate_at_100c: float = 2e-3,
                    activation_j_per_mol: float = 50e3, step_s: float = 5.0) -> np.ndarray:
    """m(t), 1 at the start: dm/dt = -k(T) (m - p_sat(T_0) / p_sat(T)), k Arrhenius, Euler steps."""
    order = np.argsort(time_s, kind="stable")
    t, temp = time_s[order], t_c[order]
    fine = np.arange(t[0], t[-1] + step_s, step_s)
    fine_c = np.interp(fine, t, temp)
    m = np.empty(len(fine))
    m[0] = 1.0
    for i in range(len(fine) - 1):
        t_mid = 0.5 * (fine_c[i] + fine_c[i + 1])
        k = rate_at_100c * np.exp(-activation_j_per_mol / 8.314 * (1 / (t_mid + 273.15) - 1 / 373.15))
        m[i + 1] = m[i] - step_s * k * (m[i] - saturation_pressure_pa(fine_c[0]) / saturation_pressure_pa(t_mid))
    out = np.empty(len(time_s))
    out[order] = np.interp(t, fine, m)
    return out


def with_parallel_capacitance(data: Measurements, extra_f: np.ndarray) -> Measurements:
    """The readings with ``extra_f`` in parallel with the coil (series L-R of the bridge recomputed)."""
    omega = 2 * np.pi * data.freq_hz
    z = 1.0 / (1.0 / (data.rs_ohm + 1j * omega * data.ls_h) + 1j * omega * extra_f)
    return dataclasses.replace(data, ls_h=z.imag / omega, rs_ohm=z.real)


@pytest.fixture(scope="module")
def drying_campaign() -> tuple[Measurements, np.ndarray]:
    lab = SimulatedLab(LabConfig(physics="field", former={"moisture": {"enabled": False}}, seed=3))
    air = campaign.coil_heating(lab, (40, 60, 80, 100, 120), interval_s=120.0)
    moisture = sorbed_moisture(air.time_s, air.t_coil_c)
    return with_parallel_capacitance(air, MOIST_DC_F * moisture), moisture


def test_the_law_follows_moisture_that_dries_toward_the_sorption_equilibrium(drying_campaign):
    data, moisture = drying_campaign
    assert moisture.min() < 0.2 and moisture[-1] > moisture.min() + 0.02  # dried hot, took some back cooling
    result = run_diagnosis(data)
    assert result.claimed[:1] == ["parasitic_capacitance"], [(c.effect, c.rejected) for c in result.candidates]
    assert result.final.rmse_ppm <= 1.5 * result.noise_ppm
    final = result.final.fit
    assert final.values["bound_share"] > 0.5
    assert final.values["moist_dC"] == pytest.approx(MOIST_DC_F, rel=0.2)
    effect = next(e for e in final.model.effects if e.name == "parasitic_capacitance")
    fitted_dc = final.values["moist_dC"] * effect.moisture(data, final.values)
    assert np.sqrt(np.mean((fitted_dc - MOIST_DC_F * moisture) ** 2)) < 0.05 * MOIST_DC_F


def test_free_water_alone_cannot_follow_it(drying_campaign):
    data, _ = drying_campaign
    plain = fit(data, ["parasitic_capacitance"], fixed={"bound_share": 0.0})
    sorbing = fit(data, ["parasitic_capacitance"])
    assert sorbing.rms_ppm < 0.5 * plain.rms_ppm
    assert sorbing.bic < plain.bic - 100
