"""plate_recession: a thick plate's screening depth per frequency, testable only at two frequencies; one plate
thickness shared with target_tau_temperature; a curvature in temperature needs a temperature inside the span."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.library.target_tau_temperature import skin_depth_m
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.model.temperature_levels import curvature_unseen

COPPER_RHO = 1.68e-8


def _data(freqs_hz: tuple[float, ...], t_target_c: tuple[float, ...] = (22.0,)) -> Measurements:
    """Nine positions at every frequency and target temperature (made-up readings: only the inputs matter)."""
    x = np.repeat(np.linspace(0.02, 0.10, 9), len(freqs_hz) * len(t_target_c))
    f = np.tile(np.repeat(freqs_hz, len(t_target_c)), 9).astype(float)
    t = np.tile(np.array(t_target_c, float), 9 * len(freqs_hz))
    n = len(x)
    return Measurements(time_s=np.arange(n, dtype=float), x_m=x, freq_hz=f, t_coil_c=np.full(n, 22.0),
                        t_target_c=t, ls_h=np.full(n, 0.05), rs_ohm=np.full(n, 50.0))


def _set_back(model: SensorModel, data: Measurements, **values: float) -> np.ndarray:
    p = {q.name: q.value for q in model.parameters()} | values
    return model.inputs(data, p).x_m - data.x_m


def test_a_thick_plate_recedes_by_half_the_skin_depth_and_a_sheet_by_a_third_of_its_thickness():
    data = _data((500.0, 15000.0))
    model = SensorModel(SensorConfig(), ["plate_recession"])
    thick = _set_back(model, data, plate_thickness=45e-3, recession_scale=1.0)
    np.testing.assert_allclose(thick, skin_depth_m(COPPER_RHO, data.freq_hz) / 2, rtol=1e-9)
    assert 1.15e-3 < thick[data.freq_hz == 500].mean() - thick[data.freq_hz == 15000].mean() < 1.25e-3  # copper
    sheet = _set_back(model, data, plate_thickness=20e-6, recession_scale=1.0)
    np.testing.assert_allclose(sheet, 20e-6 / 3, rtol=1e-3)   # alike at both frequencies: p1 takes it
    assert not np.any(_set_back(model, data, recession_scale=0.0))   # its absent form


@pytest.mark.parametrize("sensor, freqs, reason", [
    (SensorConfig(), (15000.0,), "fewer than two frequencies"),
    (SensorConfig(target="steel"), (500.0, 15000.0), "a magnetic target"),
])
def test_untestable_at_one_frequency_and_on_steel(sensor, freqs, reason):
    fixed = SensorModel(sensor, ["plate_recession"]).unidentifiable(_data(freqs))
    assert reason in fixed["recession_scale"] and reason in fixed["plate_thickness"]


def test_one_plate_thickness_for_its_recession_and_its_conductivity_change():
    """target_tau_temperature alone fixes the thickness without a target temperature span; beside
    plate_recession at two frequencies the thickness is determined by the recession."""
    cold = _data((500.0, 15000.0))
    alone = SensorModel(SensorConfig(), ["target_tau_temperature"])
    assert "plate_thickness" in alone.unidentifiable(cold)
    both = SensorModel(SensorConfig(), ["plate_recession", "target_tau_temperature"])
    assert [p.name for p in both.parameters()].count("plate_thickness") == 1
    assert "plate_thickness" not in both.unidentifiable(cold)
    assert "tau_tempco" in both.unidentifiable(cold)
    assert "plate_thickness" in both.unidentifiable(_data((15000.0,)))


def test_a_curvature_in_temperature_needs_a_temperature_inside_the_span():
    drift = np.r_[np.full(10, 22.0), np.linspace(69.9, 75.0, 10)]  # room and one hot level drifting 5 K
    assert curvature_unseen(drift) is not None
    assert curvature_unseen(np.r_[np.full(10, 22.0), np.full(10, 50.0), np.full(10, 80.0)]) is None
    assert curvature_unseen(np.linspace(20.0, 40.0, 30)) is not None  # 20 K: too short a span


def test_the_diagnosis_tries_it_only_when_named():
    """It ties with tau_displacement wherever it acts (a thick plate at two frequencies): not a default candidate."""
    from ecds_lab.analysis.diagnosis.search import default_candidates
    from ecds_lab.model.effects import library

    names = default_candidates(library())
    assert "plate_recession" not in names and "plate_recession" in library()
    assert {"tau_displacement", "target_tau_temperature", "target_bending"} <= set(names)
