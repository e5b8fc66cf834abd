"""Transcripts: every command and reply an instrument link carried, with timestamps.

A transcript is the raw material of record/replay: the run file stores one per
instrument, and the replay transport serves it back to the same driver code.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import NamedTuple

#: Event kinds: bytes the host sent (a terminated command or raw real-time bytes),
#: a line the instrument sent, or a failure seen on the link (e.g. a timeout).
SENT = "sent"
RECEIVED = "received"
ERROR = "error"
KINDS = (SENT, RECEIVED, ERROR)


class TranscriptEvent(NamedTuple):
    """One thing that crossed the link: ``text`` without termination characters."""

    clock_s: float
    wall_s: float
    kind: str
    text: str


#: Builds a TranscriptEvent from its four fields without the Python-level ``__new__`` NamedTuple generates
#: (the same tuple, one call frame less on every command and reply).
_new_event = tuple.__new__


@dataclass
class Transcript:
    """Append-only log of one instrument's traffic; cheap enough to be always on."""

    instrument: str
    events: list[TranscriptEvent] = field(default_factory=list)

    def record(self, clock_s: float, kind: str, text: str) -> None:
        self.events.append(_new_event(TranscriptEvent, (clock_s, time.time(), kind, text)))

    def __len__(self) -> int:
        return len(self.events)

    def __iter__(self) -> Iterator[TranscriptEvent]:
        return iter(self.events)

    def sent(self) -> list[str]:
        """The commands in the order they were sent (what protocol tests assert)."""
        return [e.text for e in self.events if e.kind == SENT]

    def clear(self) -> None:
        self.events.clear()
