"""The campaign's recorded heater waits as the planned waits' response (docs/planning.md, Predicted readings): the
fits on waits of known shape, and what a file without recorded waits gives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ecds_lab.config.station import ThermalConfig
from ecds_lab.planning.recorded_runs import recorded_runs
from ecds_lab.planning.recorded_waits import RecordedWait, recorded_waits
from ecds_lab.planning.thermal_response import ThermalResponse, cooling_fit, steady_after_s
from ecds_lab.runner.steady_state import SteadyState
from ecds_lab.runner.thermal_time import heating_wait_s

STEADY = SteadyState(slope_k_per_min=0.1, window_s=300.0, tolerance_k=1.0, check_interval_s=10.0, timeout_s=21600.0)


def _cooling(tau_s: float, lag_s: float, start_c: float, room_c: float) -> RecordedWait:
    """A cool-down logged every minute: flat for ``lag_s``, then first order towards ``room_c``."""
    t = np.arange(0.0, 3000.0, 60.0)
    temps = room_c + (start_c - room_c) * np.exp(-np.maximum(t - lag_s, 0.0) / tau_s)
    return RecordedWait("coil", True, 30.0, t, temps, room_c)


def test_the_cooling_fit_recovers_a_first_order_cool_down_and_its_lag():
    tau, lag, room = cooling_fit([_cooling(900.0, 0.0, 70.0, 22.0), _cooling(900.0, 0.0, 50.0, 22.0)])
    assert tau == pytest.approx(900.0, rel=1e-9) and lag == pytest.approx(0.0, abs=1e-6) and room == 22.0
    # a lag of 2 min: the logs before it sit off the line and pull it (by 1 % in tau, 11 % in the lag here)
    tau, lag, _ = cooling_fit([_cooling(900.0, 120.0, 70.0, 22.0)])
    assert tau == pytest.approx(900.0, rel=0.03) and lag == pytest.approx(120.0, rel=0.2)
    assert cooling_fit([RecordedWait("coil", True, 30.0, np.arange(3.0), np.full(3, 22.2), 22.0)]) is None


def test_a_planned_cool_down_follows_the_fitted_one_towards_the_recorded_room():
    response = ThermalResponse.of([_cooling(800.0, 0.0, 70.0, 21.0)], ThermalConfig())
    wait = response.cooling("coil", 61.0, 31.0, None)
    assert wait is not None and wait.seconds == pytest.approx(800.0 * math.log(40.0 / 10.0))
    assert wait.temperature_c(wait.seconds) == pytest.approx(31.0)
    assert response.cooling("target", 61.0, 31.0, None) is None  # nothing recorded of the target


def test_a_steady_wait_scales_with_its_step_and_ends_where_the_runner_judges_it_steady():
    """A recorded first-order wait of tau 200 s (a linear loop's shape): a step twice as large takes the same shape
    twice as high, and ends where the runner's steady judgement on the true trajectory ends it (near the
    first-order formula the runner's estimate uses: window plus tau ln(step / allowed error))."""
    tau, step = 200.0, 20.0
    duration = steady_after_s(STEADY, 42.0, lambda s: 42.0 - step * math.exp(-s / tau))
    t = np.arange(0.0, duration, 60.0)
    temps = 42.0 - step * np.exp(-t / tau)
    recorded = RecordedWait("target", False, 42.0, t, temps, 22.0, STEADY, duration)
    response = ThermalResponse.of([recorded], ThermalConfig())
    wait = response.heating("target", 22.0, 62.0, STEADY)
    assert wait is not None
    for s in (0.0, 120.0, 600.0):  # between the minute logs the shape is interpolated linearly
        assert wait.temperature_c(s) == pytest.approx(62.0 - 40.0 * math.exp(-s / tau), abs=0.5)
    truth = steady_after_s(STEADY, 62.0, lambda s: 62.0 - 40.0 * math.exp(-s / tau))
    # past the recorded 990 s the error left falls with the declared 300 s, not the true 200 s: a few checks off
    assert abs(wait.seconds - truth) <= 3 * STEADY.check_interval_s, (wait.seconds, truth)
    formula = heating_wait_s(STEADY, 40.0, ThermalConfig().target.model_copy(update={"settling_time_constant_s": tau}))
    assert abs(truth - formula) <= 0.15 * formula  # the estimate's formula approximates the same judgement
    assert wait.seconds > duration  # a larger step takes longer to come within the same error
    assert response.heating("target", 62.0, 22.0, STEADY) is None  # no recorded step downwards


def test_a_csv_or_a_missing_file_records_no_waits(tmp_path):
    csv = tmp_path / "data.csv"
    csv.write_text("time_s,x_mm,freq_hz,t_coil_c,t_target_c,ls_h,rs_ohm\n0,20,15000,22,22,0.05,50\n",
                   encoding="utf-8")
    assert recorded_waits(recorded_runs([csv, tmp_path / "missing.h5"])) == []
