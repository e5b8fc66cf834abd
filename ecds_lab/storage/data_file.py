"""A DATA argument opened: what the file is, its readings, its run metadata, and which sensor measured it.

The one answer to both questions the command line, the report and the analysis ask of a file:
a run file brings its readings, metadata and recorded sensor; a CSV brings readings only, and the
sensor its export sidecar records (data/sidecar.py) when it has one.
``--sensor`` overrides what the file says; when nothing says, the paper's copper prototype is
assumed and ``sensor_note`` says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ecds_lab.data.files import FileKind, file_kind
from ecds_lab.data.measurements import DataError, Measurements
from ecds_lab.data.run_metadata import RunMetadata
from ecds_lab.data.sensor import DEFAULT_SENSOR_NOTE, SensorConfig, load_sensor
from ecds_lab.data.sidecar import read_sidecar
from ecds_lab.errors import RunFileError
from ecds_lab.storage.reader import read_measurements, read_run


@dataclass(eq=False)
class DataFile:
    """One data file: its kind, readings, run metadata (None for a CSV) and the sensor to analyse it as."""

    path: Path
    kind: FileKind
    data: Measurements
    run: RunMetadata | None
    sensor: SensorConfig
    #: where the sensor came from: ``run file``, ``export sidecar <name>``, ``--sensor <path>`` or ``not recorded``
    sensor_source: str

    @property
    def sensor_note(self) -> str | None:
        """The line analysis output shows when the sensor is assumed rather than known."""
        return DEFAULT_SENSOR_NOTE if self.sensor_source == "not recorded" else None

    def sensor_summary(self) -> dict[str, str]:
        """The sensor as the JSON outputs name it."""
        return {"name": self.sensor.name, "target": self.sensor.target, "former": self.sensor.former,
                "source": self.sensor_source}


def open_data(path: str | Path, sensor: str | Path | None = None, *, allow_empty: bool = False) -> DataFile:
    """Open a run file or CSV; ``sensor`` (a shipped name or a YAML path) overrides the recorded sensor.

    A run file without a single reading raises RunFileError, or with ``allow_empty`` opens with no
    readings and the reason among its faults (the report still lists such a run).
    """
    path = Path(path)
    kind = file_kind(path)
    run = None
    if kind == "csv":
        data = Measurements.from_csv(path)
    else:
        stored = read_run(path, transcripts=False)
        run = RunMetadata.from_attributes(stored.metadata, status=stored.status, points=len(stored.points),
                                          completed_points=len(stored.completed_points()),
                                          identities=stored.identities, source=str(path))
        run.faults.extend(note for note in stored.notes if note not in run.faults)
        try:
            data = read_measurements(stored)
        except RunFileError as exc:
            if not allow_empty:
                raise
            run.faults.append(str(exc))
            data = no_readings(str(path))
    if sensor is not None:
        return DataFile(path, kind, data, run, load_sensor(sensor), f"--sensor {sensor}")
    if run is not None and run.sensor is not None:
        return DataFile(path, kind, data, run, run.sensor, "run file")
    exported = read_sidecar(path) if kind == "csv" else None
    if exported is not None and exported.sensor is not None:
        return DataFile(path, kind, data, run, exported.sensor, f"export sidecar {exported.path.name}")
    return DataFile(path, kind, data, run, SensorConfig(), "not recorded")


def no_readings(source: str) -> Measurements:
    """Measurements with no rows (a run that failed before its first reading)."""
    empty = np.zeros(0)
    return Measurements(empty, empty, empty, empty, empty, empty, empty, source=source)


@dataclass(eq=False)
class Campaign:
    """Several data files analysed as one campaign: their readings joined, one sensor for all."""

    files: list[DataFile]
    data: Measurements

    @property
    def sensor(self) -> SensorConfig:
        return self.files[0].sensor

    @property
    def sensor_note(self) -> str | None:
        return self.files[0].sensor_note

    def sensor_summary(self) -> dict[str, str]:
        return self.files[0].sensor_summary()


def open_campaign(paths: Sequence[str | Path], sensor: str | Path | None = None) -> Campaign:
    """Open every file (each its own recording); files that record different sensors are refused by name."""
    files = [open_data(p, sensor) for p in paths]
    first = files[0]
    for other in files[1:]:
        if other.sensor != first.sensor:
            raise DataError(f"{other.path}: measured with sensor {other.sensor.name!r}, but {first.path} with "
                            f"{first.sensor.name!r}; analyse them separately, or name one sensor with --sensor")
    data = first.data if len(files) == 1 else Measurements.concatenate([f.data for f in files])
    return Campaign(files, data)
