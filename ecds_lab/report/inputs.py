"""What the report was given: each data file's readings, run metadata and sensor, and its use.

Files are opened by ``storage.data_file.open_data``, the one place that decides what a file is
and which sensor measured it: a run file brings its metadata (experiment, station, identities,
status, times, point counts, faults) and its recorded sensor; a CSV brings only its readings.
Each input is also sorted by what it can be used for: impedance spectroscopy (coil in air at
four or more frequencies) or the sensor model (everything else), grouped by target material.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.run_metadata import RunMetadata
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.storage.data_file import DataFile, open_data

#: Coil-in-air readings at this many frequencies or more make an input a spectroscopy recording.
SPECTROSCOPY_MIN_FREQUENCIES = 4
#: Target material of the paper's prototype, the sensor assumed when a file records none.
DEFAULT_TARGET = SensorConfig().target


@dataclass(eq=False)
class ReportInput:
    """One DATA argument: its readings, its run metadata (None for CSV), its sensor and its use in the report."""

    file: DataFile

    @property
    def path(self) -> Path:
        return self.file.path

    @property
    def data(self) -> Measurements:
        return self.file.data

    @property
    def run(self) -> RunMetadata | None:
        return self.file.run

    @property
    def sensor(self) -> SensorConfig:
        return self.file.sensor

    @property
    def sensor_note(self) -> str | None:
        """Set when the sensor is assumed (not recorded in the file)."""
        return self.file.sensor_note

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
        return self.sensor.target

    @property
    def lab_duration_s(self) -> float:
        """Span of the readings' time stamps (the lab's clock, which a simulation may run fast)."""
        return float(np.ptp(self.data.time_s)) if len(self.data) else 0.0


def load_inputs(paths: list[Path]) -> list[ReportInput]:
    """Open every DATA path (run file or CSV); errors name the file.

    A run file without a single reading (a run that failed at once) is still listed, with no data.
    """
    return [ReportInput(open_data(path, allow_empty=True)) for path in map(Path, paths)]
