"""The transcript log: every instrument's commands and replies in one table of a run file.

``/entry/transcripts/log`` is a 1-D compound dataset, one record per event or part of an event:

  clock_s    f8   the run clock when the event crossed the link (s)
  wall_s     f8   the wall clock then (s since the Unix epoch)
  role       u1   index into the dataset's ``roles`` attribute (bridge, slide, ...)
  continues  u1   1: the event's text goes on in the next record (same role, kind and times)
  size       u1   the text bytes this record holds (exact even for a text that ends in NUL bytes)
  text       S48  UTF-8 text, NUL-padded
  kind       u1   index into its ``kinds`` attribute (sent, received, error); 255: never written

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

import struct
from collections.abc import Iterable, Sequence

import h5py
import numpy as np

from ecds_lab.storage.recovery import unreadable_rows
from ecds_lab.transports.transcript import KINDS, TranscriptEvent

LOG_NAME = "log"
TEXT_BYTES = 48
RECORD = np.dtype([("clock_s", "<f8"), ("wall_s", "<f8"), ("role", "u1"), ("continues", "u1"), ("size", "u1"),
                   ("text", f"S{TEXT_BYTES}"), ("kind", "u1")])
#: The kind of a record never written: the fill value of the log.
UNWRITTEN = 255
#: A record packed as RECORD lays it out (little-endian, no padding): what the writer appends.
_PACK = struct.Struct(f"<ddBBB{TEXT_BYTES}sB").pack
assert struct.calcsize(f"<ddBBB{TEXT_BYTES}sB") == RECORD.itemsize
FILL = np.array((np.nan, np.nan, UNWRITTEN, 0, 0, b"", UNWRITTEN), dtype=RECORD)[()]
KIND_CODES = {kind: code for code, kind in enumerate(KINDS)}
#: Records per chunk: the log is appended (and its last chunk rewritten) once per point, so chunks
#: stay small (64 x 68 bytes).
CHUNK_RECORDS = 64


def create_log(group: h5py.Group, roles: Sequence[str]) -> h5py.Dataset:
    """The empty log in ``group``, self-describing: role and kind names and the units as attributes."""
    if len(roles) >= UNWRITTEN:
        raise ValueError(f"a transcript log holds at most {UNWRITTEN - 1} roles, not {len(roles)}")
    log = group.create_dataset(LOG_NAME, shape=(0,), maxshape=(None,), dtype=RECORD, chunks=(CHUNK_RECORDS,),
                               fillvalue=FILL)
    log.attrs.update({"roles": list(roles), "kinds": list(KINDS), "clock_s_units": "s", "wall_s_units": "s",
                      "text_encoding": "utf-8"})
    return log


def encode(role: int, events: Iterable[tuple[float, float, str, str]], into: list[bytes]) -> None:
    """Append the records of ``events`` (clock_s, wall_s, kind, text) of one role to ``into``, packed.

    Packed with ``struct``, not built as a numpy array: a point brings a handful of events, too few
    for numpy's per-call cost to pay off (packing is about half the cost of assigning tuples)."""
    pack = _PACK
    for clock_s, wall_s, kind, text in events:
        data = text.encode("utf-8", errors="replace")
        size = len(data)
        if size <= TEXT_BYTES:
            into.append(pack(clock_s, wall_s, role, 0, size, data, KIND_CODES[kind]))
            continue
        code = KIND_CODES[kind]
        last = (size - 1) // TEXT_BYTES * TEXT_BYTES
        into.extend(pack(clock_s, wall_s, role, int(start < last), min(TEXT_BYTES, size - start),
                         data[start:start + TEXT_BYTES], code) for start in range(0, size, TEXT_BYTES))


def read_log(log: h5py.Dataset, file_size: int) -> dict[str, list[TranscriptEvent]]:
    """role -> its events, from the records on disk before the first lost or unwritten one; an event
    whose continuation is missing (a killed writer) is left out."""
    roles = [_text(r) for r in log.attrs["roles"]]
    kinds = [_text(k) for k in log.attrs["kinds"]]
    lost = unreadable_rows(log, file_size)
    records = log[:int(np.argmax(lost)) if lost.any() else None]
    unwritten = records["kind"] == UNWRITTEN
    if unwritten.any():
        records = records[:int(np.argmax(unwritten))]
    ends = np.flatnonzero(records["continues"] == 0)  # each event's last record
    records = records[:ends[-1] + 1 if len(ends) else 0]  # records after the last one: an event cut off
    blob = np.ascontiguousarray(records["text"]).tobytes()  # with every NUL byte: ``size`` says where text ends
    pieces = [blob[at:at + size]
              for at, size in zip(range(0, len(blob), TEXT_BYTES), records["size"].tolist(), strict=True)]
    starts = [0, *(ends[:-1] + 1).tolist()][:len(ends)]  # each event's first record
    texts = [(pieces[end] if start == end else b"".join(pieces[start:end + 1])).decode("utf-8")
             for start, end in zip(starts, ends.tolist(), strict=True)]
    out: dict[str, list[TranscriptEvent]] = {role: [] for role in roles}
    per_role = [out[role] for role in roles]
    kind_names = [kinds[code] for code in records["kind"][ends].tolist()]
    for role, clock_s, wall_s, kind, text in zip(records["role"][ends].tolist(), records["clock_s"][ends].tolist(),
                                                 records["wall_s"][ends].tolist(), kind_names, texts, strict=True):
        per_role[role].append(TranscriptEvent(clock_s, wall_s, kind, text))
    return out


def _text(value: bytes | str) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)
