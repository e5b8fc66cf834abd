"""``ecds-lab export``: a run file's readings as CSV, every column by default, units in a sidecar.

The CSV stays in the import format (DESIGN.md): its first seven columns are the import columns
with their exact header names, so the file re-imports. The remaining run-file columns follow.
Every reading is a row; a value not known (no position yet) is ``nan``. Units and descriptions, the
direction of each reading and the station's declared figures (sensor, slide repeatability) go to a
JSON sidecar (data/sidecar.py; a units row would break the import format), so the CSV re-imports to
the same analysis as the run file.
Numbers: the shortest text that reads back as the stored float (Python's repr) when that text has at
most 15 significant digits; a value carrying arithmetic noise in its 16th-17th digit (a simulated
time 6.739999999999998, a power V*I 55.428867600000004) is written to 15 digits (6.74, 55.4288676),
within 5e-15 (relative) of the stored value. Any text written reads back as a float that is written as the
same text again (15 digits survive decimal -> binary -> decimal), so exports round-trip exactly.
No parquet: pyarrow is a heavy dependency for a format the CSV and the HDF5 file already cover.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from ecds_lab.data.columns import COLUMNS, INDEX
from ecds_lab.data.measurements import CSV_COLUMNS
from ecds_lab.data.run_metadata import REPEATABILITY_ATTRIBUTE, recorded_repeatability, recorded_sensor
from ecds_lab.data.sidecar import sidecar_path
from ecds_lab.errors import EcdsLabError
from ecds_lab.storage.outputs import OutputError, replacing
from ecds_lab.storage.reader import read_run

#: Import column -> the run-file column it comes from (the rest keep their names).
_IMPORT_SOURCES = {"x_mm": "x_commanded_mm"}
_UNITS = {c.name: (c.unit, c.description) for c in COLUMNS}
IMPORT_COLUMNS = tuple(CSV_COLUMNS)
ALL_COLUMNS = IMPORT_COLUMNS + tuple(c.name for c in COLUMNS
                                     if c.name not in IMPORT_COLUMNS and c.name not in _IMPORT_SOURCES.values())


def number(value: float) -> str:
    """``value`` without float noise, as text that round-trips (integers without '.0'; 'inf', 'nan')."""
    if math.isfinite(value) and value.is_integer() and abs(value) < 2**53:
        return str(int(value))
    shortest = repr(float(value))
    mantissa = shortest.split("e")[0].lstrip("-").replace(".", "").lstrip("0")
    return shortest if len(mantissa) <= 15 else f"{value:.15g}"


def columns_from(text: str | None) -> tuple[str, ...]:
    """``--columns a,b,c`` checked against the exportable names (None: all of them)."""
    if not text:
        return ALL_COLUMNS
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in ALL_COLUMNS]
    if unknown or not names:
        raise EcdsLabError(f"--columns: unknown column(s) {', '.join(unknown) or '(none given)'}; "
                           f"choose from {', '.join(ALL_COLUMNS)}")
    return names


@dataclass(frozen=True)
class Exported:
    """What an export wrote: every reading a row, and how many of them have no position (x_mm = nan)."""

    rows: int
    without_position: int

    def describe(self, output: Path) -> str:
        """The export's one-line summary, in the data contract's words (docs/data-contract.md)."""
        unknown = (f"; {self.without_position} of them taken before the slide had a position (x_mm = nan, "
                   "not used by the analysis)" if self.without_position else "")
        return f"{self.rows} rows (one per reading) -> {output}{unknown}"


def export_run(run_path: Path, output: Path, columns: Sequence[str] = ALL_COLUMNS) -> Exported:
    """Write every row holding a bridge reading to ``output``, and the sidecar (units, directions, station).

    A value the run does not know (no position yet, a failed temperature reading) is written as ``nan``;
    no reading is left out. The sidecar (data/sidecar.py) makes the CSV re-import to the same analysis.
    """
    run = read_run(run_path, transcripts=False)
    rows = run.points[np.isfinite(run.column("ls_h"))]
    sources = [INDEX[_IMPORT_SOURCES.get(name, name)] for name in columns]
    table = rows[:, sources]
    with _written(Path(output)) as part, part.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(columns)
        writer.writerows([number(v) for v in row] for row in table.tolist())
    units = {name: dict(zip(("unit", "description"), _UNITS[_IMPORT_SOURCES.get(name, name)], strict=True))
             for name in columns}
    without_position = int(np.isnan(rows[:, INDEX["x_commanded_mm"]]).sum())
    sidecar = {"source": str(run_path), "csv": Path(output).name, "rows": len(table),
               "rows_without_position": without_position, "columns": units,
               "import_columns": list(IMPORT_COLUMNS),
               "direction": np.nan_to_num(rows[:, INDEX["direction"]]).astype(int).tolist(),
               "station": _station_figures(run.metadata, str(run_path)),
               "run": {key: str(run.metadata.get(key, "")) for key in ("experiment", "kind", "status")}}
    with _written(sidecar_path(Path(output))) as part:
        part.write_text(json.dumps(sidecar, indent=2) + "\n", encoding="utf-8")
    return Exported(len(table), without_position)


def _station_figures(attributes: dict[str, str], source: str) -> dict[str, object]:
    """The station's declared figures the run file records, as the sidecar carries them (None: undeclared)."""
    sensor = recorded_sensor(attributes, source)
    declared = str(attributes.get(REPEATABILITY_ATTRIBUTE, "")).strip()
    station = yaml.safe_load(attributes.get("station_yaml", "") or "{}")
    return {"name": str(station.get("name", "")) if isinstance(station, dict) else "",
            "sensor_name": sensor.name if sensor is not None else None,
            "sensor": sensor.model_dump(mode="json") if sensor is not None else None,
            "slide_repeatability_m": recorded_repeatability(attributes, source) if declared else None}


@contextmanager
def _written(path: Path) -> Iterator[Path]:
    """Write ``path`` through a temporary beside it, moved over it once complete (storage/outputs.py); a write
    that fails (a full disk) leaves no half-written file and becomes one OutputError naming ``path``."""
    try:
        with replacing(path) as part:
            yield part
    except OSError as exc:
        raise OutputError(f"{path}: could not be written: {exc.strerror or exc}") from exc
