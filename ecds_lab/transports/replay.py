"""Replay a recorded transcript to the same driver code, checking every command it sends.

The replay link walks the recording in order: each command the driver sends must be
the next recorded command, each read returns the next recorded reply (or the
recorded timeout). The shared simulated clock is moved to each event's recorded time,
so time-dependent decisions (settling, polling, steady-state windows) come out the same.

The links of one station share a ``ReplayState``: the first divergence on any of them
stops the whole replay (every later command or read raises the same divergence), so
what is reported is the first place the code left the recording, not a consequence.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ecds_lab.clock import SimulatedClock
from ecds_lab.errors import ReplayDivergence, TransportError
from ecds_lab.transports.base import Transport
from ecds_lab.transports.transcript import ERROR, RECEIVED, SENT, STALE, TranscriptEvent


@dataclass
class ReplayState:
    """Shared by the replay links of one station: the first divergence, after which replay has stopped."""

    divergence: ReplayDivergence | None = None


def describe_event(event: TranscriptEvent) -> str:
    """How a recorded event reads in a divergence message."""
    if event.kind == SENT:
        return f"command {event.text!r}"
    if event.kind == RECEIVED:
        return f"a read (recorded reply {event.text!r})"
    if event.kind == STALE:
        return f"a query (recorded: the stale line {event.text!r} discarded before it)"
    return f"a read (recorded {event.text})" if event.text == "timeout" else f"recorded error {event.text!r}"


class ReplayTransport(Transport):
    """A link whose far end is a recording; diverging from it raises ReplayDivergence."""

    def __init__(self, name: str, events: list[TranscriptEvent], *, clock: SimulatedClock, clock_origin_s: float = 0.0,
                 write_termination: str = "\n", read_termination: str = "\n", state: ReplayState | None = None,
                 **options: object) -> None:
        options.pop("min_interval_s", None)  # the recording already holds the pauses
        kept: dict[str, Any] = {k: v for k, v in options.items() if k in ("timeout_s", "record")}
        super().__init__(name, write_termination=write_termination, read_termination=read_termination,
                         clock=clock, min_interval_s=0.0, **kept)
        self.events = events
        self.position = 0
        self.state = state or ReplayState()
        self._clock = clock
        self._origin = clock_origin_s
        self._sending = ""

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
        """The divergence at the event just taken (or past the end), remembered as the replay's first."""
        where = (f"after the last of {len(self.events)} transcript events" if expected == "the end of the recording"
                 else f"at transcript event {self.position} of {len(self.events)}")
        divergence = ReplayDivergence(f"{self.name}: replay diverges {where}: expected {expected}, got {actual}")
        if self.state.divergence is None:
            self.state.divergence = divergence
        return divergence

    def _check_not_stopped(self) -> None:
        if self.state.divergence is not None:
            raise ReplayDivergence(str(self.state.divergence))

    def _send_logged(self, text: str, data: bytes) -> None:
        # Compare what the base link records (the command without termination, or the raw bytes
        # of write_bytes) rather than re-deriving it from the bytes.
        self._sending = text
        super()._send_logged(text, data)

    def _send(self, data: bytes) -> None:
        self._check_not_stopped()
        text = self._sending
        event = self._next()
        if event is None:
            raise self._diverge("the end of the recording", f"command {text!r}")
        if event.kind != SENT or event.text != text:
            raise self._diverge(describe_event(event), f"command {text!r}")
        following = self.events[self.position] if self.position < len(self.events) else None
        if following is not None and following.kind == ERROR and following.text != "timeout":
            self._next()
            raise TransportError(f"{self.name}: sending {text!r} failed: {following.text} (recorded)")

    def _receive_line(self, timeout_s: float) -> str | None:
        self._check_not_stopped()
        event = self._next()
        if event is None:
            raise self._diverge("the end of the recording", "a read")
        if event.kind == RECEIVED:
            return event.text
        if event.kind == ERROR:
            return None
        if event.kind == STALE:
            raise self._diverge(describe_event(event), "a read")
        raise self._diverge(f"command {event.text!r} to be sent next", "a read")

    def _waiting_line(self) -> str | None:
        """The recorded stale line next in the recording, if that is what comes next (a recording made before
        stale lines were recorded has none: nothing is discarded)."""
        if self.state.divergence is not None or self.position >= len(self.events):
            return None
        if self.events[self.position].kind != STALE:
            return None
        event = self._next()
        assert event is not None
        return event.text

    def _close(self) -> None:
        """Nothing to release."""

    @property
    def finished(self) -> bool:
        return self.position >= len(self.events)

    def remaining(self) -> str:
        """Where the replay stands in the recording, for a replay that ended before the recording did."""
        if self.finished:
            return f"{self.name}: every one of the {len(self.events)} transcript events replayed"
        return (f"{self.name}: replay ended at transcript event {self.position + 1} of {len(self.events)}; "
                f"the recording continues with {describe_event(self.events[self.position])}")
