"""SteadyState: a frozen, validated criterion that describes itself; SteadinessWindow judges readings by it."""

from __future__ import annotations

import dataclasses

import pytest

from ecds_lab.runner.steady_state import SteadinessWindow, SteadyState

CRITERION = SteadyState(slope_k_per_min=0.1, window_s=300.0, tolerance_k=1.0, check_interval_s=10.0,
                        timeout_s=6 * 3600.0)


def feed(window: SteadinessWindow, temperature_at, until_s: float, every_s: float = 10.0) -> list[bool]:
    """The window's verdict after each reading of ``temperature_at(t)`` from 0 to ``until_s``."""
    return [window.add(t, temperature_at(t)) for t in (i * every_s for i in range(int(until_s / every_s) + 1))]


def test_a_flat_reading_at_the_setpoint_is_steady_once_a_full_window_has_passed():
    verdicts = feed(SteadinessWindow(CRITERION, 40.0), lambda t: 40.2, until_s=400.0)
    first_steady_s = verdicts.index(True) * 10.0
    assert first_steady_s == 300.0
    assert all(verdicts[30:])


def test_a_ramp_steeper_than_the_threshold_is_never_steady():
    ramp_k_per_s = 0.2 / 60.0  # 0.2 K/min, twice the threshold
    assert not any(feed(SteadinessWindow(CRITERION, 40.0), lambda t: 40.0 + ramp_k_per_s * (t - 600), 1200.0))


def test_a_flat_reading_away_from_the_setpoint_is_not_steady():
    assert not any(feed(SteadinessWindow(CRITERION, 40.0), lambda t: 41.5, until_s=900.0))


def test_the_criterion_is_frozen_and_none_means_no_time_limit():
    with pytest.raises(dataclasses.FrozenInstanceError):
        CRITERION.window_s = 10.0  # type: ignore[misc]
    unlimited = dataclasses.replace(CRITERION, timeout_s=None)
    assert "no time limit" in unlimited.describe()
    assert CRITERION.describe() == ("< 0.1 K/min over 5 min, within 1 K, checked every 10 s, give up after 6 h")


@pytest.mark.parametrize("field", ["slope_k_per_min", "window_s", "tolerance_k", "check_interval_s", "timeout_s"])
def test_a_non_positive_field_is_refused_by_name(field):
    with pytest.raises(ValueError, match=rf"SteadyState\.{field} must be > 0"):
        dataclasses.replace(CRITERION, **{field: 0.0})
