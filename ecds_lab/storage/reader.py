"""Read run files: the points table, metadata and transcripts, including files of killed runs.

Files are opened in SWMR-read mode, which also opens a file whose writer was killed
(its consistency flags are still set, so a plain open would refuse it). A file cut short is read
from a private repaired copy (:mod:`~ecds_lab.storage.recovery`): rows whose bytes were lost are
left out and reported in ``RunFile.notes``, never read as zeros.
"""

from __future__ import annotations

import os
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from ecds_lab.data.columns import COLUMN_NAMES, INDEX, PLANNED_POINT
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.run_metadata import recorded_link_notes, recorded_repeatability
from ecds_lab.errors import RunFileError
from ecds_lab.storage.lock import is_being_written
from ecds_lab.storage.recovery import private_folder, read_superblock, readable_copy, truncated, unreadable_rows
from ecds_lab.storage.transcript_log import LOG_NAME, read_log
from ecds_lab.transports.transcript import KINDS, TranscriptEvent


@dataclass
class RunFile:
    """Everything a run file holds, loaded into memory."""

    path: Path
    metadata: dict[str, str]
    points: np.ndarray
    transcripts: dict[str, list[TranscriptEvent]]
    #: role -> the instrument's identification string (``*IDN?`` reply or banner) at the start of the run
    identities: dict[str, str] = field(default_factory=dict)
    #: What the reader had to work around (a writer that never closed the file, lost rows), one line each.
    notes: list[str] = field(default_factory=list)

    @property
    def status(self) -> str:
        """completed / aborted / failed, or 'interrupted' for a file whose writer never closed it."""
        status = self.metadata.get("status", "unknown")
        return "interrupted" if status == "running" else status

    def column(self, name: str) -> np.ndarray:
        if name not in INDEX:
            raise KeyError(f"no column {name!r}; columns: {', '.join(COLUMN_NAMES)}")
        return self.points[:, INDEX[name]]

    def table(self) -> dict[str, np.ndarray]:
        return {name: self.column(name) for name in COLUMN_NAMES}

    def completed_points(self) -> set[int]:
        """Planned point numbers that have a reading in the file."""
        planned = self.column("kind") == PLANNED_POINT
        return {int(p) for p in self.column("point")[planned]}


def read_run(path: str | Path, *, transcripts: bool = True) -> RunFile:
    """Load a run file; a missing, truncated or foreign file raises RunFileError saying which."""
    path = Path(path)
    if not path.exists():
        raise RunFileError(f"{path}: no such run file")
    notes: list[str] = []
    try:
        with ExitStack() as stack:
            f = stack.enter_context(_open(path, notes, stack))
            if "entry" not in f or "points" not in f["entry"]:
                raise RunFileError(f"{path}: not an ecds-lab run file (no /entry/points)")
            entry = f["entry"]
            metadata = {k: (v.decode() if isinstance(v, bytes) else v if isinstance(v, str) else str(v))
                        for k, v in entry.attrs.items()}
            table = entry["points"]
            names = [c.decode() if isinstance(c, bytes) else str(c) for c in table.attrs["columns"]]
            if names != list(COLUMN_NAMES):
                raise RunFileError(f"{path}: written with other columns ({', '.join(names)}); "
                                   f"this ecds-lab reads {', '.join(COLUMN_NAMES)}")
            size = os.path.getsize(f.filename)
            lost = unreadable_rows(table, size)
            points = _read_rows(table, lost)
            if lost.any():
                notes.append(f"{int(lost.sum())} row(s) of the points table were lost from the end of the file "
                             "and are left out (never read as zeros)")
            points = points[~np.isnan(points[:, INDEX["time_s"]])]  # a row grown but never written (killed)
            notes.extend(recorded_link_notes(metadata))  # stale lines the run's links discarded
            events = _read_transcripts(entry, size) if transcripts and "transcripts" in entry else {}
            identities = _read_identities(entry)
    except RunFileError:
        raise
    except (OSError, KeyError, ValueError, RuntimeError, TypeError) as exc:  # h5py's errors for damaged files
        raise RunFileError(f"{path}: cannot read the run file (truncated or corrupt?): {exc}") from exc
    return RunFile(path, metadata, points, events, identities, notes)


def _open(path: Path, notes: list[str], stack: ExitStack) -> h5py.File:
    """Open a closed run file plainly; otherwise say why not and open what can be read.

    A plain open checks the file against the size its superblock records, so a truncated file
    fails at once. SWMR-read skips that check and retries unreadable metadata (a writer may be
    mid-flush), which on a truncated file can spin for minutes: it is kept for a live run and
    for a whole file whose writer was killed. A truncated file is read from a repaired copy.
    """
    try:
        return h5py.File(path, "r")
    except OSError:
        block = read_superblock(path)
        if block is None:
            raise
    if block.left_open and is_being_written(path):
        notes.append("a run is still writing this file (read live)")
        return h5py.File(path, "r", swmr=True)
    if block.left_open:
        notes.append("the run's writer never closed this file (killed, crashed, or a write failed on a full disk); "
                     "ecds-lab reads it from a repaired copy and leaves it as it is; other HDF5 tools need its "
                     f"write flags cleared first: h5clear -s {path}")
    elif truncated(path):
        notes.append("the file is shorter than its superblock records: it was cut short (full disk? "
                     f"interrupted copy?); read from a repaired copy, {path} itself is left as it is")
    else:
        raise RunFileError(f"{path}: cannot read the run file (corrupt?)")
    folder = stack.enter_context(private_folder())
    return h5py.File(readable_copy(path, Path(folder)), "r")


def _read_rows(dataset: h5py.Dataset, lost: np.ndarray) -> np.ndarray:
    """The rows of a dataset that are not lost, reading only the stretches that are on disk."""
    if not lost.any():
        return dataset[()]
    keep = np.flatnonzero(~lost)
    if not len(keep):
        return np.zeros((0, *dataset.shape[1:]), dataset.dtype)
    breaks = np.flatnonzero(np.diff(keep) > 1)
    starts = np.concatenate([[keep[0]], keep[breaks + 1]])
    ends = np.concatenate([keep[breaks], [keep[-1]]]) + 1
    return np.concatenate([dataset[a:b] for a, b in zip(starts, ends, strict=True)])


def _read_identities(entry: h5py.Group) -> dict[str, str]:
    """role -> identity string from /entry/instrument/<role> (roles without one are left out)."""
    if "instrument" not in entry:
        return {}
    out = {}
    for role, group in entry["instrument"].items():
        identity = group.attrs.get("identity") if isinstance(group, h5py.Group) else None
        if identity is not None:
            out[role] = identity.decode() if isinstance(identity, bytes) else str(identity)
    return out


def _read_transcripts(entry: h5py.Group, file_size: int) -> dict[str, list[TranscriptEvent]]:
    """role -> its events: from the one transcript log, or from a file written before it (one group per role)."""
    transcripts = entry["transcripts"]
    if LOG_NAME in transcripts:
        return read_log(transcripts[LOG_NAME], file_size)
    return _read_role_groups(transcripts, file_size)


def _read_role_groups(transcripts: h5py.Group, file_size: int) -> dict[str, list[TranscriptEvent]]:
    """The layout before the transcript log (decision 0006): per role an ``events`` table (clock_s, wall_s,
    kind, text_end) and its ``text`` bytes."""
    out: dict[str, list[TranscriptEvent]] = {}
    for role, group in transcripts.items():
        lost_events = unreadable_rows(group["events"], file_size)  # keep what precedes the first loss:
        lost_text = unreadable_rows(group["text"], file_size)      # a transcript has no gaps
        table = group["events"][:int(np.argmax(lost_events)) if lost_events.any() else None]
        blob = group["text"][:int(np.argmax(lost_text)) if lost_text.any() else None].tobytes()
        # Only events whose text is fully on disk count (a killed writer may have stopped in between).
        complete = table[:, 3] <= len(blob)
        table = table[complete]
        starts = np.concatenate([[0], table[:-1, 3]]).astype(int) if len(table) else np.zeros(0, int)
        out[role] = [TranscriptEvent(row[0], row[1], KINDS[int(row[2])], blob[int(s):int(row[3])].decode("utf-8"))
                     for row, s in zip(table, starts, strict=True)]
    return out


def located(x_commanded_mm: np.ndarray) -> np.ndarray:
    """Rows recorded where the slide's position was known (a distance, or +inf with the coil in air): the
    readings a run's measurements hold. After homing, until the slide's first move, a reading has no distance."""
    return ~np.isnan(np.asarray(x_commanded_mm, float))


def read_measurements(run: RunFile | str | Path) -> Measurements:
    """The bridge readings of a run file (or one already read) as Measurements (rows with a reading)."""
    if not isinstance(run, RunFile):
        run = read_run(run, transcripts=False)
    path = run.path
    ok = np.isfinite(run.column("ls_h")) & located(run.column("x_commanded_mm"))
    if not ok.any():
        raise RunFileError(f"{path}: holds no bridge readings")
    rows = run.points[ok]

    def pick(name: str) -> np.ndarray:
        return rows[:, INDEX[name]]

    direction = pick("direction")
    repeatability = recorded_repeatability(run.metadata, str(path))
    return Measurements(
        time_s=pick("time_s"), x_m=pick("x_commanded_mm") * 1e-3, freq_hz=pick("freq_hz"),
        t_coil_c=pick("t_coil_c"), t_target_c=pick("t_target_c"), ls_h=pick("ls_h"), rs_ohm=pick("rs_ohm"),
        direction=np.nan_to_num(direction).astype(int), slide_repeatability_m=np.full(len(rows), repeatability),
        source=str(path),
    )
