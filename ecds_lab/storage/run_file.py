"""Write a run file: one HDF5 file per run, every point flushed as it is measured.

Layout (NeXus-flavoured, so generic viewers find their way):
  /entry                     NXentry: status, times, software, experiment and station YAML,
                             the sensor description (JSON; absent when the station names none)
  /entry/points              (N x C) float64 table, one row per reading, appended and flushed
                             per point (SWMR: a viewer can read it live; a killed run keeps
                             every row written)
  /entry/data                NXdata: one 1-D view per column (signal ls_h, axis x_commanded_mm);
                             it, the NXlogs and a plot per run kind (root @default): storage/nexus.py
  /entry/instrument/<role>   identity, driver, settings
  /entry/instrument/thermocouples/<name>   NXlog (time, value)
  /entry/transcripts/<role>  every command and reply: events (clock_s, wall_s, kind, end) + text bytes
The table is the source of truth; NXdata and NXlogs are views onto it, live during the run; the
status and end_time are completed at close (a killed run's file says status 'running').

Data safety: a writer lock beside the file (:mod:`~ecds_lab.storage.lock`) admits one writer per
path; each point's transcript events are on disk before its row; the file is completed at close
without reopening it (no window in which a kill leaves a complete run unreadable, and a live SWMR
reader cannot block the close); a write that fails (full disk) raises RunFileError and the rows
already flushed stay readable.
"""

from __future__ import annotations

import json
import math
import operator
import os
import sys
from collections.abc import Mapping, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ecds_lab import __version__
from ecds_lab.data.columns import COLUMN_NAMES, COLUMNS, INDEX
from ecds_lab.data.run_metadata import SENSOR_ATTRIBUTE, sensor_attribute
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.errors import RunFileError
from ecds_lab.storage.lock import WriterLock
from ecds_lab.storage.nexus import NexusLayout, finish, sweep_shape
from ecds_lab.transports.transcript import KINDS, Transcript

#: The points table is flushed every row, and each row rewrites its whole chunk: small chunks
#: (32 rows, 5 KB) keep that cheap. Columns written once at close use large chunks.
_TABLE_CHUNK_ROWS = 32
#: Transcripts are appended (and flushed) with every point, so their chunks are small too.
_EVENT_CHUNK_ROWS = 64
_TEXT_CHUNK = 2048
_KIND_CODES = {kind: float(code) for code, kind in enumerate(KINDS)}
_IN_COLUMN_ORDER = operator.itemgetter(*COLUMN_NAMES)


def _now_iso() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _quiet_about_unwritable_metadata(unraisable: sys.UnraisableHookArgs) -> None:
    """Once a run file failed a write, h5py reports each freed object's failed metadata write as
    "Exception ignored"; the run's own error already said it, once. Anything else is reported as usual."""
    if isinstance(unraisable.exc_value, RuntimeError) and "file write failed" in str(unraisable.exc_value):
        return
    sys.__unraisablehook__(unraisable)


#: Writers whose file failed a write: kept referenced so that no HDF5 object of theirs is ever freed.
BROKEN_WRITERS: list[RunWriter] = []


class _Appender:
    """Appends to a chunked dataset (1-D, or 2-D growing along rows), flushed per call.

    The last chunk is kept in memory and written whole with H5Dwrite_chunk: per point this costs
    a memory copy, not h5py's selection machinery. The points table and the transcripts use it.
    """

    def __init__(self, dataset: h5py.Dataset, fill: float) -> None:
        self.id = dataset.id
        self.chunk = dataset.chunks[0]
        self.width = dataset.shape[1:]
        self._origin_rest = tuple(0 for _ in self.width)
        self.length = dataset.shape[0]
        self.fill = fill
        self.tail = np.full((self.chunk, *self.width), fill, dtype=dataset.dtype)

    def append(self, values: Sequence[Any] | np.ndarray) -> None:
        """Grow, write the chunks the values fall in, and flush; ``values`` is an array or a list of rows."""
        count = len(values)
        if not count:
            return
        first = self.length
        ident, chunk, tail = self.id, self.chunk, self.tail
        ident.set_extent((first + count, *self.width))
        done = 0
        while done < count:
            row = first + done
            offset = row % chunk
            take = min(chunk - offset, count - done)
            if offset == 0:
                tail.fill(self.fill)
            tail[offset:offset + take] = values[done:done + take] if done or take < count else values
            ident.write_direct_chunk((row - offset, *self._origin_rest), tail.tobytes())
            done += take
        ident.flush()
        self.length = first + count


class RunWriter:
    """Appends rows to a new run file; ``close`` records how the run ended."""

    def __init__(self, path: Path, *, metadata: Mapping[str, str], transcripts: Mapping[str, Transcript],
                 identities: Mapping[str, str] | None = None, overwrite: bool = False) -> None:
        self.path = Path(path)
        self._file: h5py.File | None = None
        #: True once a write failed (full disk): the file keeps what was flushed and is not touched again.
        self.broken = False
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._lock = WriterLock(self.path)
        except OSError as exc:
            raise RunFileError(f"{self.path}: cannot write in {self.path.parent}: {exc.strerror or exc}") from exc
        try:
            if self.path.exists() and not overwrite:
                raise RunFileError(f"{self.path} exists; choose another -o or pass --overwrite")
            self._file = h5py.File(self.path, "w", libver="latest")
            self._transcripts = dict(transcripts)
            self._event_tables: dict[str, tuple[_Appender, _Appender]] = {}
            self._written_events = {role: 0 for role in self._transcripts}
            self._create_layout(metadata, identities or {})
            self._file.swmr_mode = True
        except BaseException as exc:
            self._abandon()
            if isinstance(exc, OSError):
                raise RunFileError(f"{self.path}: cannot create the run file: {exc}") from exc
            raise

    @property
    def rows(self) -> int:
        """Rows written to the points table so far."""
        return self._points.length

    def _abandon(self) -> None:
        """Close the file handle whatever state it is in, and release the writer lock."""
        if self._file is not None:
            try:
                self._file.close()
            except Exception:  # a file that cannot even close has nothing left to save
                pass
            self._file = None
        self._lock.release()

    def _create_layout(self, metadata: Mapping[str, str], identities: Mapping[str, str]) -> None:
        assert self._file is not None
        entry = self._file.create_group("entry")
        entry.attrs.update({"NX_class": "NXentry", "status": "running", "start_time": _now_iso(),
                            "software": f"ecds-lab {__version__}"})
        for key, value in metadata.items():
            entry.attrs[key] = value
        table = entry.create_dataset("points", shape=(0, len(COLUMNS)), maxshape=(None, len(COLUMNS)),
                                     dtype="<f8", chunks=(_TABLE_CHUNK_ROWS, len(COLUMNS)), fillvalue=np.nan)
        table.attrs["columns"] = list(COLUMN_NAMES)
        table.attrs["units"] = [c.unit for c in COLUMNS]
        self._points = _Appender(table, np.nan)
        instrument = entry.create_group("instrument")
        instrument.attrs["NX_class"] = "NXinstrument"
        for role, identity in identities.items():
            group = instrument.create_group(role)
            group.attrs.update({"NX_class": "NXcollection", "identity": identity})
        self._nexus = NexusLayout(self._file, table, metadata.get("kind", ""), sweep_shape(metadata))
        records = entry.create_group("transcripts")
        records.attrs.update({"NX_class": "NXcollection", "kinds": list(KINDS)})
        for role in self._transcripts:
            group = records.create_group(role)
            events = group.create_dataset("events", shape=(0, 4), maxshape=(None, 4), dtype="<f8",
                                          chunks=(_EVENT_CHUNK_ROWS, 4))
            text = group.create_dataset("text", shape=(0,), maxshape=(None,), dtype="u1", chunks=(_TEXT_CHUNK,))
            events.attrs["columns"] = ["clock_s", "wall_s", "kind", "text_end"]
            self._event_tables[role] = (_Appender(events, np.nan), _Appender(text, 0))

    # -- per point ------------------------------------------------------------------------
    def append(self, values: Mapping[str, float]) -> None:
        """Append one reading and flush it to disk before returning; columns not given are NaN."""
        if values.keys() == INDEX.keys():  # the runner gives every column
            row = _IN_COLUMN_ORDER(values)
        else:
            unknown = values.keys() - INDEX.keys()
            if unknown:
                raise RunFileError(f"unknown run file column(s): {', '.join(sorted(unknown))}")
            row = tuple(values.get(name, math.nan) for name in COLUMN_NAMES)
        self.write_transcripts()  # the traffic that produced this row is on disk before the row
        self._write_rows((row,))

    def append_rows(self, rows: np.ndarray) -> None:
        """Append a block of finished rows (used when a resumed run copies its predecessor)."""
        if len(rows):
            self._write_rows(np.asarray(rows, float).reshape(-1, len(COLUMNS)))

    def _write_rows(self, rows: Sequence[Sequence[float]] | np.ndarray) -> None:
        """Grow the table, write the chunks the rows fall in, and flush (:class:`_Appender`: the last
        chunk kept in memory and written whole, about 3x cheaper per point than a one-row hyperslab
        write). Rows past the end of the table stay NaN, its fill value."""
        if self.broken:
            raise RunFileError(f"{self.path}: no longer writable after a failed write")
        try:
            self._points.append(rows)
            self._nexus.rows_written(rows)
        except (OSError, RuntimeError) as exc:
            raise self._write_failed(exc) from exc

    def _write_failed(self, exc: BaseException) -> RunFileError:
        """The error a failed write becomes (a full disk, a file-size limit, a vanished folder).

        After a failed write the HDF5 library holds metadata it cannot write; every further call,
        even closing or freeing an object, tries again and fails (at interpreter exit it can crash).
        So the file is never touched again: the writer is kept alive in :data:`BROKEN_WRITERS`
        and the command line ends the process without the library's shutdown (``exit_now``).
        """
        self.broken = True
        BROKEN_WRITERS.append(self)
        sys.unraisablehook = _quiet_about_unwritable_metadata
        return RunFileError(f"{self.path}: writing the run file failed (disk full?): {exc}; "
                            f"the {self.rows} rows written before are kept")

    @property
    def roles(self) -> tuple[str, ...]:
        """The instruments whose transcripts this file records."""
        return tuple(self._transcripts)

    def add_transcript_events(self, role: str, events: Sequence[tuple[float, float, str, str]]) -> None:
        """Append earlier transcript events (a resumed run keeps its predecessor's traffic)."""
        self._append_events(role, events)

    def write_transcripts(self) -> None:
        """Write (and flush) transcript events recorded since the last call."""
        if self.broken:
            raise RunFileError(f"{self.path}: no longer writable after a failed write")
        try:
            for role, transcript in self._transcripts.items():
                start, events = self._written_events[role], transcript.events
                if len(events) > start:
                    new = events[start:]
                    self._append_events(role, new)
                    self._written_events[role] = start + len(new)
        except (OSError, RuntimeError) as exc:
            raise self._write_failed(exc) from exc

    def _append_events(self, role: str, events: Sequence[tuple[float, float, str, str]]) -> None:
        """Append (clock_s, wall_s, kind, text) events: a numeric table and the texts as one byte blob.

        Built with plain Python lists: a point brings one to three events, too few for numpy's
        per-call overhead to pay off."""
        if not events:
            return
        events_out, text_out = self._event_tables[role]
        end = text_out.length
        encoded = []
        rows = []
        for clock_s, wall_s, kind, text in events:
            data = text.encode("utf-8", errors="replace")
            end += len(data)
            encoded.append(data)
            rows.append((clock_s, wall_s, _KIND_CODES[kind], end))
        text_out.append(np.frombuffer(b"".join(encoded), dtype="u1"))  # text first: an event never points past it
        events_out.append(rows)

    # -- the end ----------------------------------------------------------------------------
    def close(self, status: str, error: str = "", extra: Mapping[str, str] | None = None) -> None:
        """Write the remaining transcripts, complete NXdata, NXlogs and the status, and close.

        All of it happens in the file as it is open (SWMR write): no reopen, so a kill at any moment
        leaves at worst a file whose status still says running, and a reader holding the file open
        cannot make the close fail. A failure here (full disk) is raised as RunFileError after the
        file is closed as far as possible.
        """
        if self._file is None:
            return
        if self.broken:
            self._lock.release()
            return
        self._check_room_to_complete()
        try:
            self.write_transcripts()
            self._complete(status, error, extra)
            self._file.flush()
        except (OSError, RuntimeError, RunFileError) as exc:
            failure = exc if isinstance(exc, RunFileError) else self._write_failed(exc)
            self._lock.release()
            raise failure from exc
        self._file.close()
        self._file = None
        self._finish_nexus()
        self._lock.release()

    def _check_room_to_complete(self) -> None:
        """Completing writes metadata and (for NeXus) reopens the file; with less free space than the
        table's size and a margin it could fail half-way and could leave the file unreadable, so the file is left as the
        last flushed row left it (a reader sees an interrupted run with every row) and the run fails."""
        needed = 2 * self.rows * len(COLUMNS) * 8 + (1 << 20)
        try:
            stats = os.statvfs(self.path.parent)
        except OSError:
            return
        if stats.f_bavail * stats.f_frsize < needed:
            self.broken = True
            BROKEN_WRITERS.append(self)
            self._lock.release()
            raise RunFileError(f"{self.path}: the disk is (nearly) full: {stats.f_bavail * stats.f_frsize} bytes free, "
                               f"{needed} needed to complete the file; it keeps its {self.rows} rows and reads as an "
                               "interrupted run")

    def _complete(self, status: str, error: str, extra: Mapping[str, str] | None) -> None:
        """How the run ended, as attributes of /entry written in place (status last)."""
        assert self._file is not None
        entry = self._file["entry"]
        entry.attrs.update({"end_time": _now_iso(), "points": self.rows})
        if error:
            entry.attrs["error"] = error
        for key, value in (extra or {}).items():
            entry.attrs[key] = value
        entry.attrs["status"] = status

    def _finish_nexus(self) -> None:
        """Add the NXentry ``end_time`` field, which needs the file open outside SWMR. The run is
        complete without it: a reader holding the file (its lock) or a kill here costs only that field."""
        try:
            with h5py.File(self.path, "a", libver="latest") as f:
                finish(f["entry"])
        except OSError:
            pass

def metadata_for(experiment_yaml: str, station_yaml: str, experiment_name: str, kind: str,
                 operator_note: str = "", *, sensor: SensorConfig | None = None, **more: str) -> dict[str, str]:
    """The metadata every run file carries (the YAML exactly as given, the station's sensor if it names one)."""
    recorded = {SENSOR_ATTRIBUTE: sensor_attribute(sensor)} if sensor is not None else {}
    return {"experiment_yaml": experiment_yaml, "station_yaml": station_yaml, "experiment": experiment_name,
            "kind": kind, "operator_note": operator_note, **recorded,
            **{k: (v if isinstance(v, str) else json.dumps(v)) for k, v in more.items()}}
