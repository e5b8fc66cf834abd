"""pytest plugin (installed with ecds-lab): fixtures for testing code against recorded sessions.

    def test_my_analysis(recorded_station):
        station = recorded_station("tests/data/sessions/sweep.h5")
        station.bridge.configure(...)      # must send what the recording holds
        reading = station.bridge.measure() # returns the recorded reply, parsed by today's driver

A command that differs from the recording raises ReplayDivergence naming the instrument,
the position in the transcript, and the expected and actual command.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from ecds_lab.station import Station


@pytest.fixture
def recorded_station() -> Iterator[Callable[[str | Path], Station]]:
    """Open a recorded run file as a Station whose instruments replay its transcripts."""
    from ecds_lab.replay import replay_station

    opened: list[Station] = []

    def open_recording(path: str | Path) -> Station:
        station = replay_station(path)
        opened.append(station)
        return station

    yield open_recording
    for station in opened:
        station.close()
