"""Fixtures of the runner tests: the stations a run opened, events at a simulated time, safe-state checks."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pytest

import ecds_lab.runner.session
from ecds_lab.clock import SimulatedClock
from ecds_lab.data.columns import COLUMN_NAMES
from ecds_lab.station import Station
from ecds_lab.storage.reader import read_run
from ecds_lab.transports.transcript import SENT


def all_off_commands(outputs: int, heater_outputs: tuple[int, ...] = (1, 2)) -> list[str]:
    """What making safe puts on the wire (drivers/hmp.py): master switch off, every output disarmed, then
    the switch-off verified: master read back, and each heater output's state and current."""
    return (["OUTP:GEN OFF"] + [c for n in range(1, outputs + 1) for c in (f"INST OUT{n}", "OUTP:SEL OFF")]
            + ["OUTP:GEN?"] + [c for n in heater_outputs for c in (f"INST OUT{n}", "OUTP?", "MEAS:CURR?")])


@pytest.fixture
def opened_stations(monkeypatch: pytest.MonkeyPatch) -> list[Station]:
    """Every Station that run_experiment opens (its ``.lab`` is the SimulatedLab behind the simulators)."""
    stations: list[Station] = []
    real_open = ecds_lab.runner.session.open_station

    def keep(*args: Any, **kwargs: Any) -> Station:
        station = real_open(*args, **kwargs)
        stations.append(station)
        return station

    monkeypatch.setattr(ecds_lab.runner.session, "open_station", keep)
    return stations


@pytest.fixture
def at_simulated_time(monkeypatch: pytest.MonkeyPatch) -> Callable[[float, Callable[[], None]], list[float]]:
    """``at_simulated_time(1800, action)``: run ``action`` once, when a simulated clock first sleeps past 1800 s.

    ``action`` may be an exception class, which is then raised there (``KeyboardInterrupt``: Ctrl-C
    arriving while the runner or a driver waits). Returns a list that receives the simulated time
    at which the action ran.
    """
    real_sleep = SimulatedClock.sleep

    def install(after_s: float, action: Callable[[], None] | type[BaseException]) -> list[float]:
        fired: list[float] = []

        def sleep(self: SimulatedClock, seconds: float) -> None:
            real_sleep(self, seconds)
            if not fired and self.now() >= after_s:
                fired.append(self.now())
                if isinstance(action, type) and issubclass(action, BaseException):
                    raise action
                action()

        monkeypatch.setattr(SimulatedClock, "sleep", sleep)
        return fired

    return install


@pytest.fixture
def assert_heater_off() -> Callable[..., None]:
    """Check that a run left the heater off: the simulated supply's outputs, the heater's transcript in
    memory and (given the run file) the transcript the file recorded all end with the all-off commands."""

    def check(station: Station, run_file: Path | None = None) -> None:
        assert station.lab is not None
        assert {n: out.on for n, out in station.lab.supply.items()} == {n: False for n in station.lab.supply}
        expected = all_off_commands(station.heater.outputs)
        assert station.transports["heater"].transcript.sent()[-len(expected):] == expected
        if run_file is not None:
            recorded = [e.text for e in read_run(run_file).transcripts["heater"] if e.kind == SENT]
            assert recorded[-len(expected):] == expected

    return check


class RowsInMemory:
    """Takes the rows a Runner appends (what RunWriter.append_row receives), by column name, for runs that need
    no file."""

    def __init__(self) -> None:
        self.rows: list[dict[str, float]] = []

    def append_row(self, row: Sequence[float]) -> None:
        self.rows.append(dict(zip(COLUMN_NAMES, row, strict=True)))


@pytest.fixture
def rows_in_memory() -> RowsInMemory:
    return RowsInMemory()
