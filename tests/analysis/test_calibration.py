"""Calibration (Section 5): noise-limited position errors, n = 4 vs n = 31, inversion and figures of merit."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.analysis.calibration import (
    calibrate,
    estimate_positions,
    noise_limited_error_m,
    position_errors,
    select_positions,
    temperature_stability_ppm_fs_per_k,
)
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.parameters import values_of
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.simulators.campaign import PAPER_POSITIONS_MM, displacement_sweep
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

NOISE = LabConfig().noise.bridge_relative["slow"]


@pytest.fixture(scope="module", params=[15000.0, 500.0], ids=["15kHz", "500Hz"])
def sweeps(request):
    """A calibration sweep (with the coil in air) and an independent evaluation sweep, 30 readings per x."""
    lab = SimulatedLab(LabConfig(seed=21))
    frequency = (request.param,)
    calibration = displacement_sweep(lab, frequencies_hz=frequency, repeats=5, air_repeats=10)
    evaluation = displacement_sweep(lab, frequencies_hz=frequency, repeats=15)
    return calibration, evaluation


def _bound_by_position(calibration, evaluation) -> np.ndarray:
    rows = evaluation.select(np.isfinite(evaluation.x_m))
    bound = noise_limited_error_m(calibration.fit.model, calibration.fit.values, rows, NOISE) * 1e3
    positions = np.unique(np.round(rows.x_m, 7))
    return np.array([bound[np.isclose(rows.x_m, x)].mean() for x in positions])


def test_all_point_calibration_is_noise_limited_at_every_position(sweeps):
    cal_data, evaluation = sweeps
    cal = calibrate(cal_data)
    assert cal.n_points == 31 and cal.fs_m == pytest.approx(0.08)
    positions_mm, rms_mm = position_errors(cal, evaluation).rms_by_position_mm()
    bound_mm = _bound_by_position(cal, evaluation)
    np.testing.assert_allclose(positions_mm, PAPER_POSITIONS_MM, atol=1e-3)
    assert np.all(rms_mm <= 1.5 * bound_mm), (rms_mm / bound_mm).max()


def test_four_point_calibration_is_within_twice_the_full_one(sweeps):
    cal_data, evaluation = sweeps
    full = calibrate(cal_data)
    few = calibrate(cal_data, n_points=4)
    assert few.n_points == 4 and few.fs_m == full.fs_m
    _, rms_full = position_errors(full, evaluation).rms_by_position_mm()
    _, rms_few = position_errors(few, evaluation).rms_by_position_mm()
    assert np.all(rms_few <= 2 * rms_full), (rms_few / rms_full).max()


def test_four_points_lie_in_the_sensitive_near_region():
    x = np.array(PAPER_POSITIONS_MM) * 1e-3
    chosen = select_positions(np.r_[x, np.inf], 4)
    assert len(chosen) == 4 and len(np.unique(chosen)) == 4
    assert chosen[0] == x.min() and chosen[-1] < x.min() + 0.5 * np.ptp(x)
    assert set(np.round(chosen, 7)) <= set(np.round(x, 7))
    np.testing.assert_array_equal(select_positions(x), np.unique(np.round(x, 7)))


def test_inversion_recovers_the_distance_of_model_readings_and_flags_out_of_range():
    model = SensorModel()
    p = values_of(model.parameters()) | {"alpha": 2e-5}
    x = np.r_[np.linspace(0.021, 0.099, 50), 0.005, 0.3, np.inf]
    n = len(x)
    rng = np.random.default_rng(0)
    data = Measurements(np.arange(n, dtype=float), x, rng.choice([500.0, 15000.0], n), rng.uniform(20, 120, n),
                        np.full(n, 22.0), np.ones(n), np.ones(n))
    data.ls_h = model.predict(data, p)
    x_est, out = estimate_positions(model, p, data, (0.01, 0.12))
    np.testing.assert_allclose(x_est[:50], x[:50], atol=1e-9)
    assert list(out) == [False] * 50 + [True, True, False]
    assert x_est[50] == 0.01 and x_est[51] == 0.12 and np.isinf(x_est[52])


def test_temperature_stability_is_error_per_full_scale_per_kelvin():
    ts = temperature_stability_ppm_fs_per_k(np.array([80e-6, -16e-6]), 0.08, np.array([100.0, 20.0]))
    np.testing.assert_allclose(ts, [10.0, -10.0])


def test_a_clamped_estimate_or_an_error_of_full_scale_is_no_position_error():
    from ecds_lab.analysis.calibration import PositionErrors

    x_ref = np.array([0.020, 0.030, 0.040, 0.020])
    x_est = np.array([0.02003, 0.02998, 0.100, 0.100])  # the last two: clamped to the far end
    errors = PositionErrors(x_ref, x_est, 0.080, np.array([False, False, True, False]))
    assert errors.in_range.tolist() == [True, True, False, False]
    assert errors.max_abs_mm() == pytest.approx(0.03)
    nothing = PositionErrors(x_ref[2:], x_est[2:], 0.080, np.array([True, False]))
    assert np.isnan(nothing.max_abs_mm())
