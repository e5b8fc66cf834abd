"""What a run file holds right now: rows, status, latest readings, the plan's progress and ETA.

Read through SWMR so a file being written (or left by a killed writer) opens without h5clear.
"""

from __future__ import annotations

import itertools
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from ecds_lab.data.columns import COLUMN_NAMES, INDEX, PLANNED_POINT
from ecds_lab.runner.progress import PlanEstimate

#: A 'running' file unchanged this long is shown as stalled: its writer may have died (a killed run's
#: file keeps saying 'running'), or it waits on something slow; the page says which it cannot tell.
STALLED_AFTER_S = 300.0


@dataclass
class Snapshot:
    """One look at a run file."""

    path: Path
    status: str = "waiting for the run file"
    kind: str = ""
    name: str = ""
    points: np.ndarray = field(default_factory=lambda: np.empty((0, len(COLUMN_NAMES))))
    planned_rows: int = 0
    expected_rows: int = 0
    remaining_s: float | None = None
    error: str = ""
    modified_s_ago: float | None = None

    def column(self, name: str) -> np.ndarray:
        return self.points[:, INDEX[name]]

    def latest(self) -> dict[str, float | None]:
        """The last row's readings (None where not measured)."""
        if not len(self.points):
            return {}
        row = self.points[-1]
        return {name: (None if not math.isfinite(v) else float(v)) for name, v in zip(COLUMN_NAMES, row, strict=True)}

    def to_json(self) -> dict[str, object]:
        from ecds_lab.live.figures import plotted_points

        rows = len(self.points)
        return {"file": str(self.path), "status": self.status, "kind": self.kind, "name": self.name,
                "rows": rows, "expected_rows": self.expected_rows,
                "plotted_points": plotted_points(self),
                "fraction": min(rows / self.expected_rows, 1.0) if self.expected_rows else 0.0,
                "remaining_s": self.remaining_s, "error": self.error, "latest": self.latest(),
                "modified_s_ago": self.modified_s_ago}


def _text(value: object) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def read_snapshot(path: Path) -> Snapshot:
    """Read the file as it is now; a missing or not-yet-readable file gives a 'waiting' snapshot."""
    path = Path(path)
    snap = Snapshot(path)
    try:
        with h5py.File(path, "r", swmr=True) as f:
            entry = f["entry"]
            attrs = {k: _text(v) for k, v in entry.attrs.items()}
            points = entry["points"][()]
    except (OSError, KeyError):
        return snap
    snap.points = points[np.isfinite(points[:, INDEX["time_s"]])]
    snap.status = attrs.get("status", "unknown")
    snap.kind, snap.name, snap.error = attrs.get("kind", ""), attrs.get("experiment", ""), attrs.get("error", "")
    snap.modified_s_ago = max(time.time() - os.path.getmtime(path), 0.0)
    if snap.status == "running" and snap.modified_s_ago > STALLED_AFTER_S:
        snap.status = "stalled"
        snap.error = (f"no new data for {snap.modified_s_ago / 60:.0f} min: the run may have been killed "
                      "(its file then keeps every row written so far; resume it with ecds-lab run --resume; "
                      f"h5dump and a plain h5py open need `h5clear -s {path}` first)")
    if snap.status == "running" and "experiment_yaml" in attrs:
        _estimate(snap, attrs["experiment_yaml"], attrs.get("station_yaml", ""))
    else:
        snap.expected_rows, snap.remaining_s = len(snap.points), 0.0
    return snap


def _estimate(snap: Snapshot, experiment_yaml: str, station_yaml: str) -> None:
    """Progress from the plan's estimate (with the station's thermal figures), calibrated by the steps the
    file shows finished."""
    import yaml

    from ecds_lab.config.station import ThermalConfig
    from ecds_lab.runner.plan import build_plan
    from ecds_lab.runner.session import load_experiment

    try:
        station = yaml.safe_load(station_yaml) if station_yaml else None
        thermal = ThermalConfig.model_validate((station or {}).get("thermal") or {})
        plan = build_plan(load_experiment("run file", experiment_yaml), thermal)
    except Exception:  # a file whose recorded experiment or station no longer validates: show rows only
        return
    estimate = PlanEstimate(plan)
    if not len(snap.points):
        snap.expected_rows, snap.remaining_s = estimate.total_rows(0, 0, 0), estimate.remaining_s(0, 0.0)
        return
    steps, times = snap.column("step").astype(int), snap.column("time_s")
    firsts = {int(s): float(times[np.argmax(steps == s)]) for s in np.unique(steps)}
    ordered = sorted(firsts)
    for before, after in itertools.pairwise(ordered):
        if after == before + 1 or estimate.steps[before].category == "heat":
            estimate.observe(before, firsts[after] - firsts[before])
    current = ordered[-1]
    in_step = float(times[-1]) - firsts[current]
    rows_in_step = int(np.count_nonzero(steps == current))
    snap.expected_rows = estimate.total_rows(current, len(snap.points), rows_in_step)
    remaining = estimate.remaining_s(current, in_step)
    walls = snap.column("wall_time_s")
    sim, wall = float(times[-1] - times[0]), float(walls[-1] - walls[0])
    snap.remaining_s = remaining * (wall / sim) if sim > 0 else remaining
    snap.planned_rows = int(np.count_nonzero(snap.column("kind") == PLANNED_POINT))
