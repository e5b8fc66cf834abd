"""Integration along time for effects with a memory: the vectorised recurrences against their definitions."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.model.library.history import first_order_lag, linear_recurrence, relaxation, relaxation_derivatives


def stepwise_relaxation(time_s: np.ndarray, rate: np.ndarray, target: np.ndarray, start: float) -> np.ndarray:
    """dy/dt = -rate (y - target), one interval at a time (rate and target constant over each)."""
    y = [start]
    for dt, r, u in zip(np.diff(time_s), rate, target, strict=True):
        y.append(u + (y[-1] - u) * np.exp(-r * max(dt, 0.0)))
    return np.array(y)


def test_relaxation_follows_its_recurrence_through_long_gaps_and_repeated_times():
    rng = np.random.default_rng(1)
    time_s = np.cumsum(rng.uniform(0.0, 100.0, 3000))
    time_s[700] = time_s[699]  # two readings at once
    time_s[2000:] += 1e6  # a night between two parts: thousands of e-folds in one interval
    rate = rng.uniform(0.0, 0.05, 2999)
    target = rng.uniform(0.0, 1.0, 2999)
    expected = stepwise_relaxation(time_s, rate, target, 1.0)
    assert relaxation(time_s, rate, target, 1.0) == pytest.approx(expected, abs=1e-10)


def test_relaxation_toward_a_fixed_target_is_exponential():
    time_s = np.linspace(0.0, 3600.0, 61)
    y = relaxation(time_s, np.full(60, 1.0 / 600), np.full(60, 0.2), 1.0)
    assert y == pytest.approx(0.2 + 0.8 * np.exp(-time_s / 600), rel=1e-12)


def test_first_order_lag_trails_a_ramp_by_its_time_constant():
    time_s = np.linspace(0.0, 20000.0, 401)
    lagged = first_order_lag(time_s, 1e-3 * time_s, 300.0)
    assert lagged[-1] == pytest.approx(1e-3 * (time_s[-1] - 300.0), rel=1e-9)


def test_relaxation_restarts_where_a_new_recording_begins():
    time_s = np.array([0.0, 100.0, 200.0, 50.0, 150.0])  # the second recording's clock starts anew
    restart = np.array([False, False, True, False])
    y = relaxation(time_s, np.full(4, 0.01), np.zeros(4), 1.0, restart=restart)
    assert y == pytest.approx([1.0, np.exp(-1.0), np.exp(-2.0), 1.0, np.exp(-1.0)], rel=1e-12)


def test_recurrences_over_the_same_decays_share_their_chunks_and_each_follows_its_own_target():
    """A value and its derivatives integrate one timeline with equal decays: the chunks cut for the first call serve
    the next (``history._chunks``), and each still follows its own recurrence."""
    rng = np.random.default_rng(4)
    time_s = np.cumsum(rng.uniform(0.0, 100.0, 5000))  # enough chunks for the heads' own recurrence
    rate = rng.uniform(0.0, 0.05, 4999)
    targets = [rng.uniform(0.0, 1.0, 4999) for _ in range(3)]
    for target in targets:
        assert relaxation(time_s, rate, target, 1.0) == pytest.approx(
            stepwise_relaxation(time_s, rate, target, 1.0), abs=1e-10)


@pytest.mark.parametrize("largest_efolds", [0.05, 3.0])
def test_series_that_share_their_decays_are_integrated_together_each_as_alone(largest_efolds):
    """Several series solved at once (forward substitution) agree with each alone (chunked sums) and with the
    recurrence stepped through in extended precision, restarts (a decay that forgets the past) included."""
    rng = np.random.default_rng(5)
    efolds = rng.uniform(0.0, largest_efolds, 4999)
    efolds[2500] = 1e4
    series = rng.normal(size=(3, 4999))
    together = linear_recurrence(efolds, series, 0.5)
    assert together.shape == (3, 5000)
    decay = np.exp(-efolds.astype(np.longdouble))
    for row, b in zip(together, series, strict=True):
        stepped = np.empty(5000, np.longdouble)
        stepped[0] = 0.5
        for i, (a, term) in enumerate(zip(decay, b.astype(np.longdouble), strict=True)):
            stepped[i + 1] = a * stepped[i] + term
        assert row == pytest.approx(stepped.astype(float), rel=1e-12, abs=1e-12)
        # one series alone is summed in chunks: exact to about 1e-11 of its scale, not to rounding
        assert row == pytest.approx(linear_recurrence(efolds, b, 0.5), rel=0, abs=1e-11 * np.abs(row).max())


def test_the_derivatives_of_a_relaxation_are_those_of_its_recurrence():
    """``relaxation_derivatives``, one row per parameter moving the rate or the target, against central differences
    of ``relaxation`` itself, restarts included."""
    rng = np.random.default_rng(6)
    time_s = np.cumsum(rng.uniform(0.0, 60.0, 800))
    restart = np.zeros(799, bool)
    restart[400] = True
    rate, target = rng.uniform(0.001, 0.02, 799), rng.uniform(0.0, 1.0, 799)
    d_rate, d_target = rng.normal(size=(2, 799)) * [[0.005], [0.0]], rng.normal(size=(2, 799)) * [[0.0], [0.3]]
    y = relaxation(time_s, rate, target, 1.0, restart=restart)
    derivatives = relaxation_derivatives(time_s, rate, target, y, d_rate, d_target, restart)
    h = 1e-4  # the recurrence is exact to ~1e-12, not to rounding: a smaller step differences that away
    for row, (dr, dt) in enumerate(zip(d_rate, d_target, strict=True)):
        ahead = relaxation(time_s, rate + h * dr, target + h * dt, 1.0, restart=restart)
        behind = relaxation(time_s, rate - h * dr, target - h * dt, 1.0, restart=restart)
        assert derivatives[row] == pytest.approx((ahead - behind) / (2 * h), rel=1e-5, abs=1e-8)
