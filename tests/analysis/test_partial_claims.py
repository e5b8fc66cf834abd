"""What a claim leaves where it acts, beyond what the same states show where it does not act."""

from __future__ import annotations

import numpy as np

from ecds_lab.analysis.diagnosis.search import beyond_idle_states
from ecds_lab.data.measurements import Measurements


def _cold_and_hot_sweeps() -> Measurements:
    x = np.tile(np.repeat(np.linspace(0.02, 0.10, 17), 2), 2)
    n = len(x)
    return Measurements(time_s=np.arange(n, dtype=float), x_m=x, freq_hz=np.tile([500.0, 15000.0], n // 2),
                        t_coil_c=np.full(n, 22.0), t_target_c=np.repeat([22.0, 75.0], n // 2),
                        ls_h=np.full(n, 0.05), rs_ohm=np.full(n, 50.0))


def test_a_bump_in_x_shown_cold_and_hot_alike_is_not_left_by_an_effect_of_the_hot_target():
    data = _cold_and_hot_sweeps()
    hot = data.t_target_c > 50
    bump = 200.0 * np.exp(-(((data.x_mm - 45.0) / 6.0) ** 2))
    noise = np.random.default_rng(1).normal(0, 1.0, len(data))
    left = beyond_idle_states(data, bump + noise, hot)
    assert np.abs(left[hot]).max() < 5.0  # the bump is the cold sweep's as well
    np.testing.assert_array_equal(left[~hot], (bump + noise)[~hot])


def test_what_only_the_hot_readings_show_is_left():
    data = _cold_and_hot_sweeps()
    hot = data.t_target_c > 50
    offset = np.where(hot, 100.0 * (data.x_mm / 100.0), 0.0)
    left = beyond_idle_states(data, offset, hot)
    np.testing.assert_allclose(left, offset)


def test_an_effect_acting_on_every_reading_keeps_its_residual():
    data = _cold_and_hot_sweeps()
    residual = np.random.default_rng(2).normal(0, 1.0, len(data))
    np.testing.assert_array_equal(beyond_idle_states(data, residual, np.ones(len(data), bool)), residual)
