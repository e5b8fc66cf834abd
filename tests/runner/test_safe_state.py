"""Ctrl-C and interlocks while heating: the heater ends off, the file says how the run ended, points are kept."""

from __future__ import annotations

import os
import signal
from collections.abc import Sequence

import numpy as np
import pytest

from ecds_lab.data.columns import INDEX, PLANNED_POINT
from ecds_lab.drivers.hmp import HMP4040
from ecds_lab.runner import safe_state
from ecds_lab.runner.plan import build_plan
from ecds_lab.runner.safe_state import StopSignal
from ecds_lab.runner.session import load_experiment, run_experiment
from ecds_lab.station import load_station_config
from ecds_lab.storage.reader import read_run
from ecds_lab.storage.run_file import RunWriter

HEATING = "target_heating_copper.yaml"
#: Simulated time at which faults arrive: past the first (ambient) sweep, while heating to the second setpoint.
MID_HEATING_S = 1800.0


def run_heating(*args, **kwargs):
    """run_experiment, where a KeyboardInterrupt that escapes fails the test (instead of stopping pytest)."""
    try:
        return run_experiment(*args, progress=False, **kwargs)
    except KeyboardInterrupt:
        pytest.fail("KeyboardInterrupt escaped run_experiment: the run was not closed and made safe")


@pytest.fixture
def appended(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, int]]:
    """(kind, point) of every row the runner handed to the run file, in order."""
    rows: list[tuple[int, int]] = []
    real_append = RunWriter.append_row

    def append_row(self: RunWriter, row: Sequence[float]) -> None:
        real_append(self, row)
        rows.append((int(row[INDEX["kind"]]), int(row[INDEX["point"]])))

    monkeypatch.setattr(RunWriter, "append_row", append_row)
    return rows


def test_ctrl_c_while_heating_aborts_with_the_heater_off_and_keeps_the_points(
        tmp_path, experiments_dir, opened_stations, at_simulated_time, appended, assert_heater_off):
    heater_on_at_interrupt: list[bool] = []

    def interrupt() -> None:
        lab = opened_stations[0].lab
        heater_on_at_interrupt.append(any(out.on for out in lab.supply.values()))
        raise KeyboardInterrupt

    fired = at_simulated_time(MID_HEATING_S, interrupt)
    output = tmp_path / "heating.h5"
    result = run_heating(experiments_dir / HEATING, None, output)

    assert fired and heater_on_at_interrupt == [True], "the interrupt must arrive while the heater is on"
    assert result.status == "aborted" and "Ctrl-C" in result.error
    recorded = read_run(output)
    assert recorded.status == "aborted" and "Ctrl-C" in recorded.metadata["error"]
    (station,) = opened_stations
    assert_heater_off(station, output)

    # every row measured before the interrupt is in the file, in order, and nothing else
    kinds, points = recorded.column("kind").astype(int), recorded.column("point").astype(int)
    assert list(zip(kinds, points, strict=True)) == appended
    planned = points[kinds == PLANNED_POINT]
    assert list(planned) == list(range(len(planned)))
    plan = build_plan(load_experiment(experiments_dir / HEATING))
    first_setpoint = [p for p in plan.points if p.label == plan.points[0].label]
    assert len(first_setpoint) <= len(planned) < len(plan.points)


def test_a_second_ctrl_c_cannot_skip_switching_the_heater_off(
        tmp_path, experiments_dir, opened_stations, at_simulated_time, monkeypatch, assert_heater_off):
    real_all_off = HMP4040.all_off
    completed: list[bool] = []

    def all_off_hit_by_ctrl_c(self: HMP4040) -> None:
        os.kill(os.getpid(), signal.SIGINT)  # the operator presses Ctrl-C again while the lab is made safe
        real_all_off(self)
        completed.append(True)

    monkeypatch.setattr(HMP4040, "all_off", all_off_hit_by_ctrl_c)
    at_simulated_time(MID_HEATING_S, KeyboardInterrupt)
    output = tmp_path / "heating.h5"
    result = run_heating(experiments_dir / HEATING, None, output)

    assert completed == [True]
    assert result.status == "aborted"
    assert read_run(output).status == "aborted"
    assert_heater_off(opened_stations[0], output)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # Ctrl-C works again afterwards


def test_over_temperature_fails_the_run_naming_thermocouple_and_limit(
        tmp_path, experiments_dir, opened_stations, assert_heater_off):
    station_config, _ = load_station_config(None)
    # the config check refuses setpoints at or above the limit; lower it after that check, below the 2nd setpoint
    setpoints = load_experiment(experiments_dir / HEATING).heating.setpoints_c
    limit = (setpoints[0] + setpoints[1]) / 2
    safety = station_config.safety.model_copy(
        update={"max_temperature_c": {**station_config.safety.max_temperature_c, "target": limit}})
    output = tmp_path / "hot.h5"
    result = run_heating(experiments_dir / HEATING, None, output, station_overrides={"safety": safety})

    assert result.status == "failed"
    assert result.error.startswith("SafetyInterlock")
    assert "target thermocouple" in result.error and f"{limit:g} C limit" in result.error
    reading = float(result.error.split("reads ")[1].split(" C")[0])
    assert reading >= limit  # the message shows 0.1 C: a reading just above the limit prints as the limit
    recorded = read_run(output)
    assert recorded.status == "failed" and recorded.metadata["error"] == result.error
    assert np.nanmax(recorded.column("t_target_c")) <= limit  # every recorded reading was within the limit
    assert_heater_off(opened_stations[0], output)


def test_open_thermocouple_while_heating_fails_the_run_naming_the_channel(
        tmp_path, experiments_dir, opened_stations, at_simulated_time, assert_heater_off):
    channel = load_station_config(None)[0].scanner.options["channels"]["target"]

    def break_thermocouple() -> None:
        opened_stations[0].lab.faults.open_thermocouples.add(channel)

    fired = at_simulated_time(MID_HEATING_S, break_thermocouple)
    output = tmp_path / "open.h5"
    result = run_heating(experiments_dir / HEATING, None, output)

    assert fired
    assert result.status == "failed"
    assert result.error.startswith("SafetyInterlock") and "thermocouple" in result.error
    assert f"channel {channel}" in result.error
    recorded = read_run(output)
    assert recorded.status == "failed" and f"channel {channel}" in recorded.metadata["error"]
    assert recorded.column("time_s").max() <= fired[0] + 60  # nothing measured long after the fault
    assert_heater_off(opened_stations[0], output)


@pytest.mark.parametrize("landing", [KeyboardInterrupt, lambda: StopSignal(signal.SIGTERM)])
def test_a_stop_landing_while_the_handlers_are_set_aside_neither_skips_making_safe_nor_leaves_them_ignored(
        landing, monkeypatch):
    """A stop signal's handler runs at any moment, also while ``ctrl_c_deferred`` sets the handlers aside one by one
    (a SIGTERM still handled once SIGINT is ignored, or one pending): the body, which makes the lab safe, still
    runs, and afterwards every handler is as it was, none ignored for good."""
    before = {sig: signal.getsignal(sig) for sig in safe_state._DEFERRED}
    real_signal = signal.signal
    calls: list[int] = []

    def set_with_a_stop_landing(signum, handler):
        calls.append(signum)
        if len(calls) == 2:  # the first handler is ignored already, as a stop's handler raises
            raise landing()
        return real_signal(signum, handler)

    monkeypatch.setattr(safe_state.signal, "signal", set_with_a_stop_landing)
    made_safe = []
    with safe_state.ctrl_c_deferred():
        made_safe.append({sig: signal.getsignal(sig) for sig in safe_state._DEFERRED})
    monkeypatch.undo()
    assert made_safe and all(handler is signal.SIG_IGN for handler in made_safe[0].values())
    assert {sig: signal.getsignal(sig) for sig in safe_state._DEFERRED} == before


def _signal_with_a_stop_landing_at(call: int, landing, monkeypatch) -> None:
    """``signal.signal`` in safe_state, with a stop's handler running (raising) just before its ``call``-th use."""
    real_signal = signal.signal
    calls: list[int] = []

    def set_with_a_stop_landing(signum, handler):
        calls.append(signum)
        if len(calls) == call:
            raise landing()
        return real_signal(signum, handler)

    monkeypatch.setattr(safe_state.signal, "signal", set_with_a_stop_landing)


def test_a_stop_landing_while_the_raising_handlers_are_installed_stops_before_the_run_and_leaves_none_behind(
        monkeypatch):
    """A stop while ``stop_signals_raise`` installs its handlers one by one is raised before the body (the run has
    not started), and the handlers installed so far are taken away again."""
    before = {sig: signal.getsignal(sig) for sig in safe_state.STOP_SIGNALS}
    _signal_with_a_stop_landing_at(len(safe_state.STOP_SIGNALS), lambda: StopSignal(signal.SIGTERM), monkeypatch)
    ran = []
    with pytest.raises(StopSignal):
        with safe_state.stop_signals_raise():
            ran.append(True)
    monkeypatch.undo()
    assert not ran
    assert {sig: signal.getsignal(sig) for sig in safe_state.STOP_SIGNALS} == before


def test_a_stop_landing_while_the_handlers_are_restored_is_raised_once_all_are_restored(monkeypatch):
    """A stop while ``stop_signals_raise`` restores the handlers after the run still reaches the caller, and no
    raising handler is left installed for good."""
    before = {sig: signal.getsignal(sig) for sig in safe_state.STOP_SIGNALS}
    with pytest.raises(StopSignal):
        with safe_state.stop_signals_raise():
            _signal_with_a_stop_landing_at(1, lambda: StopSignal(signal.SIGTERM), monkeypatch)
    monkeypatch.undo()
    assert {sig: signal.getsignal(sig) for sig in safe_state.STOP_SIGNALS} == before
