"""Read run files: the points table, metadata and transcripts, including files of killed runs.

Files are opened in SWMR-read mode, which also opens a file whose writer was killed
(its consistency flags are still set, so a plain open would refuse it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from ecds_lab.data.columns import COLUMN_NAMES, INDEX, PLANNED_POINT
from ecds_lab.data.measurements import Measurements
from ecds_lab.errors import RunFileError
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
    try:
        with _open(path) as f:
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
            points = table[()]
            points = points[~np.isnan(points[:, INDEX["time_s"]])]  # a row grown but never written (killed)
            events = _read_transcripts(entry) if transcripts and "transcripts" in entry else {}
            identities = _read_identities(entry)
    except RunFileError:
        raise
    except (OSError, KeyError, ValueError, RuntimeError, TypeError) as exc:  # h5py's errors for damaged files
        raise RunFileError(f"{path}: cannot read the run file (truncated or corrupt?): {exc}") from exc
    return RunFile(path, metadata, points, events, identities)


def _open(path: Path) -> h5py.File:
    """Open a closed run file plainly; fall back to SWMR-read only for a file a writer left open.

    A plain open checks the file against the size its superblock records, so a truncated file
    fails at once. SWMR-read skips that check and retries unreadable metadata (a writer may be
    mid-flush), which on a truncated or damaged file can spin for minutes; it is kept for the
    files that need it: a live run, or one whose writer was killed (consistency flags still set).
    """
    try:
        return h5py.File(path, "r")
    except OSError:
        if not _left_open_by_writer(path):
            raise
    return h5py.File(path, "r", swmr=True)


def _left_open_by_writer(path: Path) -> bool:
    """Whether the superblock (version 2/3, as libver='latest' writes) still has its write-access flags set."""
    with open(path, "rb") as raw:
        head = raw.read(12)
    return len(head) == 12 and head[:8] == b"\x89HDF\r\n\x1a\n" and head[8] >= 2 and bool(head[11] & 0x05)


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


def _read_transcripts(entry: h5py.Group) -> dict[str, list[TranscriptEvent]]:
    out: dict[str, list[TranscriptEvent]] = {}
    for role, group in entry["transcripts"].items():
        table = group["events"][()]
        blob = group["text"][()].tobytes()
        # Only events whose text is fully on disk count (a killed writer may have stopped in between).
        complete = table[:, 3] <= len(blob)
        table = table[complete]
        starts = np.concatenate([[0], table[:-1, 3]]).astype(int) if len(table) else np.zeros(0, int)
        out[role] = [TranscriptEvent(row[0], row[1], KINDS[int(row[2])], blob[int(s):int(row[3])].decode("utf-8"))
                     for row, s in zip(table, starts, strict=True)]
    return out


def read_measurements(run: RunFile | str | Path) -> Measurements:
    """The bridge readings of a run file (or one already read) as Measurements (rows with a reading)."""
    if not isinstance(run, RunFile):
        run = read_run(run, transcripts=False)
    path = run.path
    ok = np.isfinite(run.column("ls_h")) & ~np.isnan(run.column("x_commanded_mm"))
    if not ok.any():
        raise RunFileError(f"{path}: holds no bridge readings")
    rows = run.points[ok]

    def pick(name: str) -> np.ndarray:
        return rows[:, INDEX[name]]

    direction = pick("direction")
    return Measurements(
        time_s=pick("time_s"), x_m=pick("x_commanded_mm") * 1e-3, freq_hz=pick("freq_hz"),
        t_coil_c=pick("t_coil_c"), t_target_c=pick("t_target_c"), ls_h=pick("ls_h"), rs_ohm=pick("rs_ohm"),
        direction=np.nan_to_num(direction).astype(int), source=str(path),
    )
