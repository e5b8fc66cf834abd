"""What the report was given: each data file's readings and, for run files, what the run was.

A run file (.h5) brings its metadata (experiment, station, instrument identities, status,
times, point counts, faults); a CSV brings only its name and row count. Each input is also
sorted by what it can be used for: impedance spectroscopy (coil in air at four or more
frequencies) or the sensor model (everything else), grouped by target material.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np
import yaml

from ecds_lab.analysis.dataset import Measurements, load_measurements
from ecds_lab.errors import RunFileError

#: Coil-in-air readings at this many frequencies or more make an input a spectroscopy recording.
SPECTROSCOPY_MIN_FREQUENCIES = 4
#: Target material when the input does not say (DESIGN.md: the paper's copper target).
DEFAULT_TARGET = "copper"


@dataclass
class RunInfo:
    """A run file's description of itself (strings as recorded; empty when absent)."""

    experiment: str = ""
    kind: str = ""
    station: str = ""
    status: str = ""
    start_time: str = ""
    end_time: str = ""
    points: int | None = None
    planned_points: int | None = None
    identities: dict[str, str] = field(default_factory=dict)
    faults: list[str] = field(default_factory=list)
    target: str | None = None

    @property
    def wall_duration_s(self) -> float | None:
        """End minus start wall time, when both are recorded."""
        try:
            return (datetime.fromisoformat(self.end_time) - datetime.fromisoformat(self.start_time)).total_seconds()
        except ValueError:
            return None


@dataclass(eq=False)
class ReportInput:
    """One DATA argument: its readings, its run metadata (None for CSV) and its use in the report."""

    path: Path
    data: Measurements
    run: RunInfo | None

    @property
    def name(self) -> str:
        return self.path.name

    @property
    def is_spectroscopy(self) -> bool:
        """Coil-in-air readings at four or more frequencies: a spectroscopy recording, not for the model."""
        air = self.data.in_air
        return len(np.unique(self.data.freq_hz[air])) >= SPECTROSCOPY_MIN_FREQUENCIES

    @property
    def target(self) -> str:
        return (self.run.target if self.run is not None and self.run.target else None) or DEFAULT_TARGET

    @property
    def lab_duration_s(self) -> float:
        """Span of the readings' time stamps (the lab's clock, which a simulation may run fast)."""
        return float(np.ptp(self.data.time_s)) if len(self.data) else 0.0


def load_inputs(paths: list[Path]) -> list[ReportInput]:
    """Load every DATA path (run file or CSV); errors name the file.

    A run file without a single reading (a run that failed at once) is still listed, with no data.
    """
    inputs = []
    for path in map(Path, paths):
        if not _is_run_file(path):
            inputs.append(ReportInput(path, load_measurements(path), None))
            continue
        info = read_run_info(path)
        try:
            data = load_measurements(path)
        except RunFileError as exc:
            data = _no_readings(str(path))
            info.faults.append(str(exc))
        inputs.append(ReportInput(path, data, info))
    return inputs


def _no_readings(source: str) -> Measurements:
    empty = np.zeros(0)
    return Measurements(empty, empty, empty, empty, empty, empty, empty, source=source)


def read_run_info(path: Path) -> RunInfo:
    """Metadata of a run file: experiment, station, identities, status, times, points, faults."""
    from ecds_lab.storage.reader import read_run

    run = read_run(path, transcripts=False)
    meta = run.metadata
    station_doc = _yaml_mapping(meta.get("station_yaml", ""))
    faults = []
    if meta.get("error"):
        faults.append(meta["error"])
    if run.status == "interrupted":
        faults.append("the run was interrupted: its writer never closed the file (killed or crashed)")
    elif run.status not in ("completed", "unknown") and not meta.get("error"):
        faults.append(f"the run ended as {run.status}")
    planned = _int_or_none(meta.get("planned_points"))
    done = len(run.completed_points())
    if planned is not None and done < planned:
        faults.append(f"{done} of {planned} planned points measured")
    return RunInfo(
        experiment=meta.get("experiment", ""), kind=meta.get("kind", ""),
        station=str(station_doc.get("name", "")) if station_doc else "", status=run.status,
        start_time=meta.get("start_time", ""), end_time=meta.get("end_time", ""),
        points=len(run.points), planned_points=planned, identities=dict(run.identities), faults=faults,
        target=_target_of(station_doc),
    )


def _is_run_file(path: Path) -> bool:
    return path.suffix.lower() in (".h5", ".hdf5", ".nxs")


def _yaml_mapping(text: str) -> dict:
    try:
        doc = yaml.safe_load(text) if text else None
    except yaml.YAMLError:
        return {}
    return doc if isinstance(doc, dict) else {}


def _target_of(station: dict) -> str | None:
    """The target material a station names (simulated lab's sensor block or a station-level sensor)."""
    for sensor in (((station.get("simulated") or {}).get("lab") or {}).get("sensor"), station.get("sensor")):
        if isinstance(sensor, dict) and sensor.get("target"):
            return str(sensor["target"])
    return None


def _int_or_none(value: object) -> int | None:
    try:
        return int(str(value))
    except ValueError:
        return None
