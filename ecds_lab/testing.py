"""Test helpers installed with ecds-lab: recorded sessions (a pytest fixture) and ``expected_protocol``.

Recorded sessions::

    def test_my_analysis(recorded_station):
        station = recorded_station("tests/data/sessions/sweep.h5")
        station.bridge.configure(...)      # must send what the recording holds
        reading = station.bridge.measure() # returns the recorded reply, parsed by today's driver

A command that differs from the recording raises ReplayDivergence naming the instrument,
the position in the transcript, and the expected and actual command.

Protocol tests without a simulator (as PyMeasure's ``pymeasure.test.expected_protocol``)::

    with expected_protocol(Grbl, [(None, b"\\r\\nGrbl 1.1h ['$' for help]\\r\\n"),
                                  (b"?", b"<Idle|MPos:0.000,0.000,0.000|FS:0,0>\\r\\n"),
                                  (b"$X\\n", b"[MSG:Caution: Unlocked]\\r\\nok\\r\\n")],
                           link_settings=SERIAL_SETTINGS) as grbl:
        grbl.connect()
        grbl.unlock()

Each pair is (bytes the driver must send in one write, bytes the instrument answers). ``None`` as
the command means the reply arrives unprompted (a banner, a late line); ``None`` as the reply means
the instrument says nothing. A write that differs from the next pair fails at once, naming both; on
leaving the block every pair must have been used and every reply byte read. A read with nothing left
to hand out is a timeout (TransportTimeout in the driver), as on a silent port. Time passes on a
SimulatedClock, so a driver's waits cost nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import pytest

from ecds_lab.clock import SimulatedClock
from ecds_lab.errors import EcdsLabError
from ecds_lab.station import Station
from ecds_lab.transports.base import Transport

#: Link settings a ProtocolTransport takes from a driver's SERIAL_SETTINGS-style dict (framing is ignored).
_LINK_KEYS = ("write_termination", "read_termination", "timeout_s", "min_interval_s")

InstrumentT = TypeVar("InstrumentT")
Pair = tuple[bytes | None, bytes | None]


class ProtocolMismatch(EcdsLabError, AssertionError):
    """The driver sent something other than the next expected command, or left pairs unused.

    An EcdsLabError so the transport passes it through unwrapped (as a replay's divergence)."""


class ProtocolTransport(Transport):
    """A Transport whose far end is a literal list of (command, reply) byte pairs."""

    def __init__(self, pairs: Sequence[Pair], name: str = "", **link: Any) -> None:
        super().__init__(name, clock=link.pop("clock", None) or SimulatedClock(), **link)
        for number, pair in enumerate(pairs):
            if not (isinstance(pair, tuple) and len(pair) == 2
                    and all(part is None or isinstance(part, bytes) for part in pair)):
                raise TypeError(f"pair {number} is {pair!r}; expected (bytes | None, bytes | None)")
        self.pairs = list(pairs)
        self.index = 0
        self._rx = b""
        self._terminator = self.read_termination.encode("ascii")

    def _send(self, data: bytes) -> None:
        if self.index >= len(self.pairs):
            raise ProtocolMismatch(f"sent {data!r} after all {len(self.pairs)} expected pairs were used")
        command, reply = self.pairs[self.index]
        if command != data:
            raise ProtocolMismatch(f"pair {self.index}: expected the command {command!r}, the driver sent {data!r}")
        self.index += 1
        self._rx += reply or b""

    def _receive_line(self, timeout_s: float) -> str | None:
        while self._terminator not in self._rx:
            if self.index < len(self.pairs) and self.pairs[self.index][0] is None:
                self._rx += self.pairs[self.index][1] or b""
                self.index += 1
                continue
            self.clock.sleep(timeout_s)
            return None
        line, _, self._rx = self._rx.partition(self._terminator)
        return line.decode("ascii", errors="replace").strip("\r\n")

    def _close(self) -> None:
        """Nothing to release."""

    def check_finished(self) -> None:
        """Raise ProtocolMismatch if pairs are left unused or reply bytes unread."""
        if self.index < len(self.pairs):
            left = self.pairs[self.index:]
            raise ProtocolMismatch(f"{len(left)} expected pair(s) never used, first {left[0]!r}")
        if self._rx:
            raise ProtocolMismatch(f"reply bytes never read by the driver: {self._rx!r}")


@contextmanager
def expected_protocol(
    instrument_class: Callable[..., InstrumentT],
    pairs: Sequence[Pair],
    *,
    link_settings: Mapping[str, Any] | None = None,
    name: str = "",
    **kwargs: Any,
) -> Iterator[InstrumentT]:
    """A driver over a ProtocolTransport that asserts the exact (command, reply) byte sequence.

    ``link_settings`` are the driver's link settings (terminations, timeout, pacing; serial framing
    keys are ignored); ``kwargs`` go to the driver's constructor after the transport.
    """
    link = {key: value for key, value in (link_settings or {}).items() if key in _LINK_KEYS}
    transport = ProtocolTransport(pairs, name, **link)
    instrument = instrument_class(transport, **kwargs)
    yield instrument
    transport.check_finished()


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
