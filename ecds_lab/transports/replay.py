"""Replay a recorded transcript to the same driver code, checking every command it sends.

The replay link walks the recording in order: each command the driver sends must be
the next recorded command, each read returns the next recorded reply (or the
recorded timeout). The shared simulated clock is moved to each event's recorded time,
so time-dependent decisions (settling, polling, steady-state windows) come out the same.
"""

from __future__ import annotations

from ecds_lab.clock import SimulatedClock
from ecds_lab.errors import ReplayDivergence, TransportError
from ecds_lab.transports.base import Transport
from ecds_lab.transports.transcript import ERROR, RECEIVED, SENT, TranscriptEvent


class ReplayTransport(Transport):
    """A link whose far end is a recording; diverging from it raises ReplayDivergence."""

    def __init__(self, name: str, events: list[TranscriptEvent], *, clock: SimulatedClock, clock_origin_s: float = 0.0,
                 write_termination: str = "\n", read_termination: str = "\n", **options: object) -> None:
        options.pop("min_interval_s", None)  # the recording already holds the pauses
        super().__init__(name, write_termination=write_termination, read_termination=read_termination,
                         clock=clock, min_interval_s=0.0, **{k: v for k, v in options.items()
                                                           if k in ("timeout_s", "record")})
        self.events = events
        self.position = 0
        self._clock = clock
        self._origin = clock_origin_s
        self._terminator = write_termination

    def _next(self) -> TranscriptEvent | None:
        if self.position >= len(self.events):
            return None
        event = self.events[self.position]
        self.position += 1
        target = event.clock_s - self._origin
        if target > self._clock.now():
            self._clock.advance(target - self._clock.now())
        return event

    def _diverge(self, expected: str, actual: str) -> ReplayDivergence:
        return ReplayDivergence(
            f"{self.name}: replay diverges at transcript event {self.position} of {len(self.events)}: "
            f"expected {expected}, got {actual}")

    def _send(self, data: bytes) -> None:
        text = data.decode("latin-1")
        if text.endswith(self._terminator) and self._terminator:
            text = text[: -len(self._terminator)]
        event = self._next()
        if event is None:
            raise self._diverge("the end of the recording", f"command {text!r}")
        if event.kind != SENT or event.text != text:
            described = f"command {event.text!r}" if event.kind == SENT else f"{event.kind} {event.text!r}"
            raise self._diverge(described, f"command {text!r}")
        following = self.events[self.position] if self.position < len(self.events) else None
        if following is not None and following.kind == ERROR and following.text != "timeout":
            self._next()
            raise TransportError(f"{self.name}: sending {text!r} failed: {following.text} (recorded)")

    def _receive_line(self) -> str | None:
        event = self._next()
        if event is None:
            raise self._diverge("the end of the recording", "a read")
        if event.kind == RECEIVED:
            return event.text
        if event.kind == ERROR:
            return None
        raise self._diverge(f"command {event.text!r} to be sent next", "a read")

    def _close(self) -> None:
        """Nothing to release."""

    @property
    def finished(self) -> bool:
        return self.position >= len(self.events)
