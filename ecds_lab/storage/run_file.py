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
  /entry/transcripts/log     every command and reply of every instrument, one compound record per
                             event (clock_s, wall_s, role, kind, text), appended with its point:
                             storage/transcript_log.py
The table is the source of truth; NXdata and NXlogs are views onto it, live during the run; the
status and end_time are completed at close (a killed run's file says status 'running').

Data safety: a writer lock beside the file (:mod:`~ecds_lab.storage.lock`) admits one writer per
path; each point's transcript events (every role's, in one append) are on disk before its row;
the file is completed at close without reopening it (no window in which a kill leaves a complete
run unreadable, and a live SWMR reader cannot block the close). A full disk is seen coming: every
ROOM_CHECK_ROWS rows the room left for the file (free disk space, and the process's file-size limit
where there is one) is compared with what completing it needs plus the next rows' headroom; below
that the append raises RunFileError naming the file, the run stops, and the file is completed with
status 'failed' and every row. A write that fails all the same (the disk filled faster) raises
RunFileError naming the file; the file is then never touched again (HDF5 cannot write its metadata),
keeps its flushed rows and reads as an interrupted run whose reader says so.
"""

from __future__ import annotations

import json
import math
import operator
import os
import shutil
import sys
from collections.abc import Callable, Mapping, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ecds_lab import __version__
from ecds_lab.data.columns import COLUMN_NAMES, COLUMNS, INDEX
from ecds_lab.data.run_metadata import SENSOR_ATTRIBUTE, repeatability_attribute, sensor_attribute
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.errors import RunFileError
from ecds_lab.storage.lock import WriterLock
from ecds_lab.storage.nexus import NexusLayout, finish, sweep_shape
from ecds_lab.storage.transcript_log import create_log
from ecds_lab.transports.transcript import KINDS, Transcript, pack_event

#: The points table is flushed every row, and each row rewrites its whole chunk: small chunks
#: (32 rows, 5 KB) keep that cheap. Columns written once at close use large chunks.
_TABLE_CHUNK_ROWS = 32
_IN_COLUMN_ORDER = operator.itemgetter(*COLUMN_NAMES)
#: The room left for the file is checked every this many rows (a statvfs call: about 2 us).
ROOM_CHECK_ROWS = 32
#: Kept free to complete the file beyond twice its table: completing a 250-330-row run grew its file by 6.2 KB.
COMPLETE_MARGIN_BYTES = 256 * 1024
#: Kept free for the rows (and their transcripts) written until the next check: 32 rows take about 5 KB of
#: table and up to some 30 KB of transcript (a move's status polls).
HEADROOM_BYTES = 256 * 1024


def _now_iso() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _quiet_about_unwritable_metadata(unraisable: sys.UnraisableHookArgs) -> None:
    """Once a run file failed a write, h5py reports each freed object's failed metadata write as
    "Exception ignored"; the run's own error already said it, once. Anything else is reported as usual."""
    if isinstance(unraisable.exc_value, RuntimeError) and "file write failed" in str(unraisable.exc_value):
        return
    sys.__unraisablehook__(unraisable)


def _posix_file_size_limit() -> Callable[[], int] | None:
    """The process's file-size limit (RLIMIT_FSIZE) as a function read at each check, where the system has one."""
    try:
        import resource  # POSIX-only; the writer runs without it elsewhere
    except ImportError:
        return None

    def limit() -> int:
        soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
        return sys.maxsize if soft == resource.RLIM_INFINITY else int(soft)

    return limit


_FILE_SIZE_LIMIT = _posix_file_size_limit()

#: Writers whose file failed a write: kept referenced so that no HDF5 object of theirs is ever freed.
BROKEN_WRITERS: list[RunWriter] = []


class _Appender:
    """Appends to a chunked dataset (1-D, or 2-D growing along rows; any dtype, compound too), flushed per call.

    The last chunk is kept in memory and written whole with H5Dwrite_chunk: per point this costs
    a memory copy, not h5py's selection machinery. The points table and the transcript log use it.
    ``values`` may also be ``bytes`` or a ``bytearray``: whole rows packed in the dataset's own layout (the
    transcript log's records, as :class:`~ecds_lab.transports.transcript.Transcript` packs them), copied into
    the tail as they are.
    With ``ahead`` the extent grows a whole chunk at a time, not per call (about a quarter of an append's
    cost): rows past ``length`` then hold the dataset's fill value until written, which must mark
    them as not written for a reader of a killed file, and :meth:`trim` sets the exact length.
    A flush writes the dataset's metadata (extent, chunk index); an append that changed neither (more rows
    in a chunk already written, within the extent) skips it: a direct chunk write of an unfiltered chunk
    goes to the file as it is called (H5Dwrite_chunk: no cache in between), so the rows are on disk either
    way. About every tenth transcript-log append flushes; the points table, whose extent grows per row,
    always does.
    """

    def __init__(self, dataset: h5py.Dataset, fill: Any, *, ahead: bool = False) -> None:
        self.id = dataset.id
        self.chunk = dataset.chunks[0]
        self.width = dataset.shape[1:]
        self._origin_rest = tuple(0 for _ in self.width)
        self.length = dataset.shape[0]
        self.extent = self.length
        self.ahead = ahead
        self.fill = fill
        self.tail = np.full((self.chunk, *self.width), fill, dtype=dataset.dtype)
        self._tail_bytes = self.tail.reshape(-1).view(np.uint8).data  # the same memory, as bytes
        self._row_bytes = self.tail[0].nbytes

    def append(self, values: Sequence[Any] | np.ndarray | bytes | bytearray) -> None:
        """Grow, write the chunks the values fall in, and flush; ``values`` is an array, a list of rows
        or packed rows (bytes)."""
        packed = values if isinstance(values, (bytes, bytearray)) else None
        size = self._row_bytes
        count = len(values) // size if packed is not None else len(values)
        if not count:
            return
        first = self.length
        ident, chunk, tail = self.id, self.chunk, self.tail
        end = first + count
        offset = first % chunk
        if packed is not None and offset and offset + count <= chunk and end <= self.extent:
            # the transcript log's usual append: more records into the chunk written last, nothing to flush
            self._tail_bytes[offset * size:offset * size + len(packed)] = packed
            ident.write_direct_chunk((first - offset, *self._origin_rest), tail)
            self.length = end
            return
        if packed is None and count == 1:
            self._append_one(values[0])
            return
        metadata_changed = self._grow(end)
        done = 0
        while done < count:
            row = first + done
            offset = row % chunk
            take = min(chunk - offset, count - done)
            if offset == 0:  # a chunk not written before: HDF5 allocates it and adds it to the chunk index
                tail[...] = self.fill
                metadata_changed = True
            if packed is not None:
                self._tail_bytes[offset * size:(offset + take) * size] = packed[done * size:(done + take) * size]
            else:
                tail[offset:offset + take] = values[done:done + take] if done or take < count else values
            ident.write_direct_chunk((row - offset, *self._origin_rest), tail)  # its buffer, not a copy
            done += take
        if metadata_changed:
            ident.flush()
        self.length = end

    def _append_one(self, row: Any) -> None:
        """:meth:`append` of one unpacked row, without its loop (the points table takes one row per reading)."""
        first = self.length
        end = first + 1
        self._grow(end)
        offset = first % self.chunk
        tail = self.tail
        if offset == 0:
            tail[...] = self.fill
        tail[offset] = row
        self.id.write_direct_chunk((first - offset, *self._origin_rest), tail)  # its buffer, not a copy
        self.id.flush()
        self.length = end

    def _grow(self, end: int) -> bool:
        """Extend the dataset to hold ``end`` rows (a chunk ahead with ``ahead``); True if it grew."""
        if end <= self.extent:
            return False
        self.extent = -(-end // self.chunk) * self.chunk if self.ahead else end
        self.id.set_extent((self.extent, *self.width))
        return True

    def trim(self) -> None:
        """Shrink an extent grown ahead to the rows written (at the end of the run)."""
        if self.extent != self.length:
            self.id.set_extent((self.length, *self.width))
            self.extent = self.length


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
            self._transcripts = dict(transcripts)
            #: per role, in the order of its code in the log: its transcript, and how many of its bytes are written
            self._sources = list(self._transcripts.values())
            if len({id(transcript) for transcript in self._sources}) < len(self._sources):
                raise RunFileError(f"{self.path}: one transcript is given for two roles (of "
                                   f"{', '.join(self._transcripts)}); each role's transcript carries its own code")
            self._file = h5py.File(self.path, "w", libver="latest")
            self._written = [0] * len(self._sources)
            self._create_layout(metadata, identities or {})
            for code, transcript in enumerate(self._sources):
                transcript.role = code  # its records so far and from now on carry the code this file gives it
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
        log = create_log(records, list(self._transcripts))
        self._log = _Appender(log, log.fillvalue, ahead=True)

    # -- per point ------------------------------------------------------------------------
    def append(self, values: Mapping[str, float]) -> None:
        """Append one reading and flush it to disk before returning; columns not given are NaN."""
        if values.keys() == INDEX.keys():  # every column given
            row = _IN_COLUMN_ORDER(values)
        else:
            unknown = values.keys() - INDEX.keys()
            if unknown:
                raise RunFileError(f"unknown run file column(s): {', '.join(sorted(unknown))}")
            row = tuple(values.get(name, math.nan) for name in COLUMN_NAMES)
        self.append_row(row)

    def append_row(self, row: Sequence[float]) -> None:
        """Append one reading given in column order (``COLUMN_NAMES``) and flush it to disk before returning
        (the runner's path: no column names to look up per reading)."""
        if len(row) != len(COLUMNS):
            raise RunFileError(f"a run file row has {len(COLUMNS)} values ({', '.join(COLUMN_NAMES)}), "
                               f"not {len(row)}")
        if self._points.length % ROOM_CHECK_ROWS == 0 and not self.broken:
            self._check_room_to_continue()
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
        if role not in self._transcripts:
            raise RunFileError(f"{self.path}: no transcript for {role!r}; this run records "
                               f"{', '.join(self._transcripts) or 'none'}")
        code = list(self._transcripts).index(role)
        self._append_log(b"".join(pack_event(code, clock_s, wall_s, kind, text)
                                  for clock_s, wall_s, kind, text in events))

    def write_transcripts(self) -> None:
        """Write (and flush) the transcript events of every role recorded since the last call: one append of
        the records each transcript packed as it recorded them."""
        added: list[bytearray] = []
        written = self._written
        for index, transcript in enumerate(self._sources):
            start = written[index]
            if len(transcript.records) > start:
                records = transcript.records[start:]
                written[index] = start + len(records)
                added.append(records)
        self._append_log(added[0] if len(added) == 1 else b"".join(added))

    def _append_log(self, records: bytes | bytearray) -> None:
        """One append of log records to disk, flushed (or RunFileError, the file kept as last flushed)."""
        if self.broken:
            raise RunFileError(f"{self.path}: no longer writable after a failed write")
        if not records:
            return
        try:
            self._log.append(records)
        except (OSError, RuntimeError) as exc:
            raise self._write_failed(exc) from exc

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
            self._log.trim()
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

    def _room_left(self) -> int | None:
        """Bytes this file may still grow by: the free disk space (statvfs's f_bavail x f_frsize, on every
        platform), or less under the process's file-size limit (RLIMIT_FSIZE, POSIX); None if unknown."""
        try:
            room = shutil.disk_usage(self.path.parent).free
            if _FILE_SIZE_LIMIT is not None:
                room = min(room, _FILE_SIZE_LIMIT() - os.path.getsize(self.path))
        except OSError:
            return None
        return room

    def _needed_to_complete(self) -> int:
        return 2 * self.rows * len(COLUMNS) * 8 + COMPLETE_MARGIN_BYTES

    def _check_room_to_continue(self) -> None:
        """Stop the run while the file can still be completed: with less room than completing needs plus the
        headroom of the rows until the next check, RunFileError (the run fails, and its file says so)."""
        room = self._room_left()
        needed = self._needed_to_complete() + HEADROOM_BYTES
        if room is not None and room < needed:
            raise RunFileError(f"{self.path}: the disk is nearly full ({room} bytes left for the file, {needed} kept "
                               f"free to complete it); the run stops here and the file keeps its {self.rows} rows")

    def _check_room_to_complete(self) -> None:
        """Completing writes metadata and (for NeXus) reopens the file; with less free space than the
        table's size and a margin it could fail half-way and could leave the file unreadable, so the file is left as the
        last flushed row left it (a reader sees an interrupted run with every row) and the run fails."""
        needed = self._needed_to_complete()
        free = self._room_left()
        if free is not None and free < needed:
            self.broken = True
            BROKEN_WRITERS.append(self)
            self._lock.release()
            raise RunFileError(f"{self.path}: the disk is (nearly) full: {free} bytes free, "
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
                 operator_note: str = "", *, sensor: SensorConfig | None = None,
                 slide_repeatability_um: float | None = None, **more: str) -> dict[str, str]:
    """The metadata every run file carries (the YAML exactly as given, the station's sensor if it names one,
    the slide's declared repeatability in metres if the station declares one)."""
    recorded = {SENSOR_ATTRIBUTE: sensor_attribute(sensor)} if sensor is not None else {}
    recorded |= repeatability_attribute(slide_repeatability_um)
    return {"experiment_yaml": experiment_yaml, "station_yaml": station_yaml, "experiment": experiment_name,
            "kind": kind, "operator_note": operator_note, **recorded,
            **{k: (v if isinstance(v, str) else json.dumps(v)) for k, v in more.items()}}
