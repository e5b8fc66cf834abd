"""Transcripts: every command and reply an instrument link carried, with timestamps.

A transcript is the raw material of record/replay: the run file stores one per
instrument, and the replay transport serves it back to the same driver code.

Events are packed as they are recorded, in the run file's transcript log record (decision 0007):

  clock_s    f8   the run clock when the event crossed the link (s)
  wall_s     f8   the wall clock then (s since the Unix epoch)
  role       u1   the instrument's code in the run file recording it (0 until one does)
  continues  u1   1: the event's text goes on in the next record (same role, kind and times)
  size       u1   the text bytes this record holds (exact even for a text that ends in NUL bytes)
  text       48s  UTF-8 text, NUL-padded
  kind       u1   index into KINDS; 255 (UNWRITTEN) in a log's records never written

so a run file appends the bytes recorded since its last append as they are, and a transcript keeps
68 bytes per event instead of a tuple, two floats and a str. ``kind`` is the last byte: a write cut
short leaves a record whole or without its kind (decision 0006).
"""

from __future__ import annotations

import struct
import time
from collections.abc import Iterator, Sequence
from typing import NamedTuple

#: Event kinds: bytes the host sent (a terminated command or raw real-time bytes),
#: a line the instrument sent, a failure seen on the link (e.g. a timeout), or a line found waiting
#: on the link before a query was sent and discarded, never taken as that query's reply (stale: an
#: unsolicited line, or one left from an earlier exchange). Codes are indices, so a kind is only appended.
SENT = "sent"
RECEIVED = "received"
ERROR = "error"
STALE = "stale"
KINDS = (SENT, RECEIVED, ERROR, STALE)
KIND_CODES = {kind: code for code, kind in enumerate(KINDS)}

#: Text bytes per record; a longer text goes on in the next records.
TEXT_BYTES = 48
#: One record, little-endian and unpadded: clock_s, wall_s, role, continues, size, text, kind.
RECORD_FORMAT = f"<ddBBB{TEXT_BYTES}sB"
_RECORD = struct.Struct(RECORD_FORMAT)
RECORD_BYTES = _RECORD.size
_pack = _RECORD.pack
#: Where each record's role byte sits (after the two f8 times).
ROLE_OFFSET = 16
#: The kind of a record never written (the transcript log's fill value): a reader stops there.
UNWRITTEN = 255
#: At most this many roles fit a role byte beside UNWRITTEN.
MAX_ROLES = UNWRITTEN - 1


class TranscriptEvent(NamedTuple):
    """One thing that crossed the link: ``text`` without termination characters."""

    clock_s: float
    wall_s: float
    kind: str
    text: str


def pack_event(role: int, clock_s: float, wall_s: float, kind: str, text: str) -> bytes:
    """The records of one event: one for a text of up to TEXT_BYTES UTF-8 bytes, more for a longer one
    (each marked ``continues`` but the last). A text that cannot be encoded has the bad characters replaced."""
    data = text.encode("utf-8", errors="replace")
    size = len(data)
    code = KIND_CODES[kind]
    if size <= TEXT_BYTES:
        return _RECORD.pack(clock_s, wall_s, role, 0, size, data, code)
    last = (size - 1) // TEXT_BYTES * TEXT_BYTES
    return b"".join(_RECORD.pack(clock_s, wall_s, role, int(start < last), min(TEXT_BYTES, size - start),
                                 data[start:start + TEXT_BYTES], code) for start in range(0, size, TEXT_BYTES))


def unpack_events(records: bytes | bytearray | memoryview,
                  kinds: Sequence[str] = KINDS) -> list[tuple[int, TranscriptEvent]]:
    """(role code, event) of each complete event in packed ``records``, in order, up to the first record
    never written; an event whose last record is missing (a killed writer) is left out. ``kinds`` names
    the kind codes (a run file's own ``kinds`` attribute)."""
    events: list[tuple[int, TranscriptEvent]] = []
    pieces: list[bytes] = []  # the records so far of an event that continues
    for clock_s, wall_s, role, continues, size, text, kind in _RECORD.iter_unpack(records):
        if kind == UNWRITTEN:
            break
        if continues:
            pieces.append(text[:size])
            continue
        if pieces:
            pieces.append(text[:size])
            data = b"".join(pieces)
            pieces = []
        else:
            data = text[:size]
        events.append((role, TranscriptEvent(clock_s, wall_s, kinds[kind], data.decode("utf-8"))))
    return events


class Transcript:
    """Append-only log of one instrument's traffic, kept packed (RECORD_FORMAT); cheap enough to be always on."""

    __slots__ = ("_decoded", "_decoded_bytes", "_role", "instrument", "records")

    def __init__(self, instrument: str) -> None:
        self.instrument = instrument
        #: Every event recorded, packed: what a run file appends (the bytes past what it wrote before).
        self.records = bytearray()
        self._role = 0
        self._decoded: list[TranscriptEvent] = []
        self._decoded_bytes = 0

    @property
    def role(self) -> int:
        """This instrument's code in the run file that records it (the index of its name in the log's roles)."""
        return self._role

    @role.setter
    def role(self, code: int) -> None:
        """Give the events recorded so far and from now on the code ``code`` (a run file taking the transcript)."""
        if not 0 <= code <= MAX_ROLES:
            raise ValueError(f"a transcript's role code is 0 to {MAX_ROLES}, not {code}")
        self._role = code
        records = self.records
        records[ROLE_OFFSET::RECORD_BYTES] = bytes([code]) * (len(records) // RECORD_BYTES)

    def record(self, clock_s: float, kind: str, text: str) -> None:
        data = text.encode("utf-8", "replace")
        size = len(data)
        if size <= TEXT_BYTES:  # pack_event's one-record case, inline: this runs for every command and reply
            self.records += _pack(clock_s, time.time(), self._role, 0, size, data, KIND_CODES[kind])
        else:
            self.records += pack_event(self._role, clock_s, time.time(), kind, text)

    @property
    def events(self) -> list[TranscriptEvent]:
        """The events recorded, unpacked (the records added since the last call are unpacked on this one)."""
        end = len(self.records)
        if end > self._decoded_bytes:
            added = self.records[self._decoded_bytes:end]  # a copy: recording on stays possible meanwhile
            self._decoded.extend(event for _, event in unpack_events(added))
            self._decoded_bytes = end
        return self._decoded

    def __len__(self) -> int:
        return len(self.events)

    def __iter__(self) -> Iterator[TranscriptEvent]:
        return iter(self.events)

    def sent(self) -> list[str]:
        """The commands in the order they were sent (what protocol tests assert)."""
        return [e.text for e in self.events if e.kind == SENT]

    def clear(self) -> None:
        self.records.clear()
        self._decoded = []
        self._decoded_bytes = 0
