"""The transcript log: every instrument's commands and replies in one table of a run file.

``/entry/transcripts/log`` is a 1-D compound dataset, one record per event or part of an event:

  clock_s    f8   the run clock when the event crossed the link (s)
  wall_s     f8   the wall clock then (s since the Unix epoch)
  role       u1   index into the dataset's ``roles`` attribute (bridge, slide, ...)
  continues  u1   1: the event's text goes on in the next record (same role, kind and times)
  size       u1   the text bytes this record holds (exact even for a text that ends in NUL bytes)
  text       S48  UTF-8 text, NUL-padded
  kind       u1   index into its ``kinds`` attribute (sent, received, error); 255: never written

The record is the one a :class:`~ecds_lab.transports.transcript.Transcript` packs its events into as they
are recorded (decision 0007), so the run file appends a transcript's new bytes as they are and reading
uses the transcripts' own :func:`~ecds_lab.transports.transcript.unpack_events`.
One point's traffic of every instrument is one append to this table (decision 0006); a text longer
than 48 bytes is split over consecutive records. Records never written (grown by a writer that was
killed before writing them) hold the fill value, kind 255, and end the log for a reader; an event
whose continuation was cut off is dropped, so a killed file reads back as complete events only.
``kind`` is each record's last byte: a write cut short by a kill (the kernel stops between pages)
leaves a prefix of the chunk written, so a record whose kind is written is written whole.
Files written before this log hold one group per role instead (``events`` + ``text``, read by
:mod:`~ecds_lab.storage.reader`).
"""

from __future__ import annotations

from collections.abc import Sequence

import h5py
import numpy as np

from ecds_lab.storage.recovery import unreadable_rows
from ecds_lab.transports.transcript import (
    KINDS,
    MAX_ROLES,
    RECORD_BYTES,
    ROLE_OFFSET,
    TEXT_BYTES,
    UNWRITTEN,
    TranscriptEvent,
    unpack_events,
)

LOG_NAME = "log"
#: The log's record as HDF5 (numpy) sees it: the transcripts' packed record (RECORD_FORMAT), field for field.
RECORD = np.dtype([("clock_s", "<f8"), ("wall_s", "<f8"), ("role", "u1"), ("continues", "u1"), ("size", "u1"),
                   ("text", f"S{TEXT_BYTES}"), ("kind", "u1")])
assert RECORD.itemsize == RECORD_BYTES and RECORD.fields is not None
assert RECORD.fields["role"][1] == ROLE_OFFSET and RECORD.fields["kind"][1] == RECORD_BYTES - 1
FILL = np.array((np.nan, np.nan, UNWRITTEN, 0, 0, b"", UNWRITTEN), dtype=RECORD)[()]
#: Records per chunk: the log is appended (and its last chunk rewritten) once per point, so chunks
#: stay small (64 x 68 bytes).
CHUNK_RECORDS = 64


def create_log(group: h5py.Group, roles: Sequence[str]) -> h5py.Dataset:
    """The empty log in ``group``, self-describing: role and kind names and the units as attributes."""
    if len(roles) > MAX_ROLES:
        raise ValueError(f"a transcript log holds at most {MAX_ROLES} roles, not {len(roles)}")
    log = group.create_dataset(LOG_NAME, shape=(0,), maxshape=(None,), dtype=RECORD, chunks=(CHUNK_RECORDS,),
                               fillvalue=FILL)
    log.attrs.update({"roles": list(roles), "kinds": list(KINDS), "clock_s_units": "s", "wall_s_units": "s",
                      "text_encoding": "utf-8"})
    return log


def read_log(log: h5py.Dataset, file_size: int) -> dict[str, list[TranscriptEvent]]:
    """role -> its events, from the records on disk before the first lost or unwritten one; an event
    whose continuation is missing (a killed writer) is left out."""
    roles = [_text(r) for r in log.attrs["roles"]]
    kinds = [_text(k) for k in log.attrs["kinds"]]
    lost = unreadable_rows(log, file_size)
    records = log[:int(np.argmax(lost)) if lost.any() else None]
    out: dict[str, list[TranscriptEvent]] = {role: [] for role in roles}
    per_role = [out[role] for role in roles]
    for role, event in unpack_events(np.ascontiguousarray(records).data, kinds):
        per_role[role].append(event)
    return out


def _text(value: bytes | str) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)
