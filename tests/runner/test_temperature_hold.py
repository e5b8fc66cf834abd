"""A hold at a setpoint: range, drift and largest deviation of the controlled thermocouple, and its verdict; a hold
out of tolerance becomes a warning for the operator, not a failed run."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from ecds_lab.runner.handlers import check_hold
from ecds_lab.runner.steps import CheckHold
from ecds_lab.runner.temperature_hold import HOLD_UNITS, HoldTracker


def test_a_hold_records_range_drift_and_deviation_and_judges_them():
    tracker = HoldTracker("target", 45.0, 1.0)
    for t, value in [(0.0, 45.2), (10.0, 44.9), (20.0, math.nan), (30.0, 44.6)]:
        tracker.observe(t, {"target": value, "coil": 80.0})
    record = tracker.close()
    assert (record.samples, record.t_min_c, record.t_max_c) == (3, 44.6, 45.2)
    assert record.drift_k == pytest.approx(-0.6) and record.max_deviation_k == pytest.approx(0.4)
    assert record.within_tolerance and set(record.as_dict()) == set(HOLD_UNITS)


def test_a_hold_out_of_tolerance_is_a_warning_note_and_the_run_goes_on():
    tracker = HoldTracker("target", 45.0, 1.0)
    for t, value in [(0.0, 45.0), (60.0, 40.0)]:  # the failure: the target falling during the sweep
        tracker.observe(t, {"target": value})
    run = SimpleNamespace(holding={"target": tracker}, holds=[], notes=[])
    check_hold(run, CheckHold("target", 45.0, 1.0))  # type: ignore[arg-type]
    assert run.holding == {} and not run.holds[0].within_tolerance
    assert run.notes == [f"WARNING: {run.holds[0].describe()}; the readings are kept, each with its measured "
                         "temperatures"]
    assert "OUT OF the 1 K tolerance" in run.notes[0] and "drift -5.00 K" in run.notes[0]


def test_a_check_without_its_hold_records_nothing():
    run = SimpleNamespace(holding={"target": HoldTracker("target", 90.0, 1.0)}, holds=[], notes=[])
    check_hold(run, CheckHold("target", 45.0, 1.0))  # type: ignore[arg-type]
    assert run.holds == [] and "target" in run.holding
