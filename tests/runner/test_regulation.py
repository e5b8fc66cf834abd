"""Waiting on a heater: the bridge is logged when a BridgeLog asks for it, and a timeout fails the run by name."""

from __future__ import annotations

import itertools

from ecds_lab.data.columns import LOGGED_POINT
from ecds_lab.runner.plan import Plan
from ecds_lab.runner.runner import Runner
from ecds_lab.runner.steady_state import SteadyState
from ecds_lab.runner.steps import BridgeLog, SetHeater, WaitSteady

#: Impossible to satisfy within the timeout: the window is longer than the wait.
NEVER_IN_TIME = SteadyState(slope_k_per_min=0.1, window_s=3600.0, tolerance_k=1.0, check_interval_s=10.0,
                            timeout_s=300.0)


def test_a_wait_logs_the_bridge_every_interval_and_fails_naming_heater_setpoint_and_timeout(
        open_sim_station, rows_in_memory, assert_heater_off):
    station = open_sim_station()
    bridge_log = BridgeLog(60.0, (500.0, 15000.0))
    plan = Plan("wait", "test", (SetHeater("coil", 40.0), WaitSteady("coil", 40.0, NEVER_IN_TIME, bridge_log)))
    status, error = Runner(station, plan, rows_in_memory, progress=False).run()  # type: ignore[arg-type]

    assert status == "failed"
    assert "EcdsLabError: coil not steady at 40 C after 300 s" in error
    rows = rows_in_memory.rows
    assert all(row["kind"] == LOGGED_POINT and row["point"] == -1 for row in rows)
    bursts = len(rows) // 2
    assert [row["freq_hz"] for row in rows] == [500.0, 15000.0] * bursts
    # logged at once, then each time a check finds the interval passed (the checks drift by command time)
    starts = [row["time_s"] for row in rows[::2]]
    assert starts[0] < NEVER_IN_TIME.check_interval_s
    gaps = [b - a for a, b in itertools.pairwise(starts)]
    assert all(60.0 <= gap < 60.0 + NEVER_IN_TIME.check_interval_s + 5.0 for gap in gaps), gaps
    assert bursts == len([t for t in starts if t <= 300.0 + NEVER_IN_TIME.check_interval_s]) >= 4
    assert_heater_off(station)


def test_a_wait_without_a_bridge_log_takes_no_reading(open_sim_station, rows_in_memory):
    station = open_sim_station()
    plan = Plan("wait", "test", (SetHeater("coil", 40.0), WaitSteady("coil", 40.0, NEVER_IN_TIME)))
    status, error = Runner(station, plan, rows_in_memory, progress=False).run()  # type: ignore[arg-type]
    assert status == "failed" and "not steady at 40 C after 300 s" in error
    assert rows_in_memory.rows == []
    assert "*TRG" not in station.transports["bridge"].transcript.sent()  # the bridge never triggered
