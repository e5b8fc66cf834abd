"""A steel plate on the faithful lab (docs/simulated_lab.md: mu_r 100 and 5 MS/m at 20 C, nothing else switched on):
at 15 kHz it screens the coil's field from a complex depth mu_r delta/2 (1 - j) behind its face, which the ECM's
single loop lacks and no calibration of Eq. (5) follows (docs/physics.md, "A magnetic plate")."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.analysis.diagnosis.search import default_candidates
from ecds_lab.data.sensor import SensorConfig, sensor_from
from ecds_lab.model.effects import Inputs, library
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.study.campaigns import QUIET_LAB

STEEL = sensor_from("steel plate", {"target": "steel"})
#: D = sqrt(mu_r/(2 omega mu_0 sigma)) at 15 kHz for the lab's documented steel (mu_r 100, sigma 5 MS/m).
TEXTBOOK_DEPTH_M = float(np.sqrt(100 / (2 * 2 * np.pi * 15e3 * 4e-7 * np.pi * 5e6)))


@cache
def steel_sweep():
    """Ten readings in air, then 17 positions over 20-100 mm at 15 kHz in both directions, two readings each, the
    plate at room temperature."""
    lab = SimulatedLab(LabConfig(physics="field", seed=5, sensor=STEEL, **QUIET_LAB))
    return campaign.displacement_sweep(lab, np.linspace(20.0, 100.0, 17).tolist(), (15000.0,), repeats=2,
                                       air_repeats=10)


def test_a_steel_plate_at_15_khz_is_found_to_screen_from_its_magnetic_depth():
    result = run_diagnosis(steel_sweep(), (), STEEL)
    assert result.steps[0].rmse_ppm > 2.5 * result.noise_ppm, result.explanation  # the ECM alone misfits steel
    assert result.claimed == ["magnetic_depth"], result.explanation
    assert result.final.rmse_ppm <= 1.5 * result.noise_ppm, result.explanation
    # the first-order depth, within what its next terms (u^3 of the reflection) and the plate's grade allow
    assert 0.7 < result.final.fit.values["magnetic_depth"] / TEXTBOOK_DEPTH_M < 1.5


def test_only_a_magnetic_plate_is_tried_for_it():
    assert "magnetic_depth" in default_candidates(library(), STEEL)
    assert "magnetic_depth" not in default_candidates(library(), SensorConfig())
    assert "magnetic_depth" not in default_candidates(library())  # the paper's copper prototype by default


def test_named_on_a_copper_plate_it_does_nothing():
    data = steel_sweep()
    with_it, without = SensorModel(SensorConfig(), ["magnetic_depth"]), SensorModel(SensorConfig())
    values = {p.name: p.value for p in with_it.parameters()}
    assert "magnetic_depth" in with_it.unidentifiable(data)
    np.testing.assert_array_equal(with_it.predict(data, values), without.predict(data, values))


@pytest.mark.parametrize("depth_m", [5e-3, 20e-3])
def test_its_curvature_is_the_second_order_of_a_complex_shift(depth_m):
    """Re k^2(x + D - jD) = k^2(x + D) - D^2/2 (k^2)_xx + D^4/24 (k^2)_xxxx - ...: the effect's k^2 against that
    series to fourth order (the calibrated coupling's derivatives by differences, 40-90 mm), far nearer than the shift
    alone."""
    model = SensorModel(STEEL, ["magnetic_depth"])
    values = {p.name: p.value for p in model.parameters()} | {"magnetic_depth": depth_m}
    data = steel_sweep()
    at_15_khz = data.select(np.arange(len(data)) < 11)
    d, h = depth_m, 2e-3
    shifted = np.linspace(0.04, 0.09, 11) + d

    def k2(at: np.ndarray) -> np.ndarray:
        return model.coupling_hat(at, values) ** 2

    second = (k2(shifted + h) - 2 * k2(shifted) + k2(shifted - h)) / h**2
    fourth = (k2(shifted + 2 * h) - 4 * k2(shifted + h) + 6 * k2(shifted) - 4 * k2(shifted - h)
              + k2(shifted - 2 * h)) / h**4
    series = k2(shifted) - d**2 / 2 * second + d**4 / 24 * fourth
    inputs = Inputs(shifted, np.full(11, 20.0), np.full(11, 20.0))
    shaped = model.effects[0].coupling_squared(k2(shifted), inputs, at_15_khz, values,
                                               lambda at: model.coupling_hat(at, values))
    assert np.max(np.abs(shaped - series)) < 0.2 * np.max(np.abs(k2(shifted) - series))
