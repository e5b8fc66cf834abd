"""The sidecar of an exported CSV (``RUN.units.json``): what the CSV cannot say in its columns.

``ecds-lab export`` writes it next to the CSV (storage/export.py): the unit of every column, the
direction of approach of each reading, and the station's declared figures the run file records (the
sensor's description, the slide's positioning repeatability). Reading a CSV reads its sidecar too, so
an exported CSV is analysed exactly as its run file is: the direction is taken, not inferred from the
order of positions, and the repeatability and sensor are kept. A CSV without a sidecar (written by
hand or by another program) is read as before: direction inferred, repeatability 0, sensor assumed.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from ecds_lab.data.sensor import SensorConfig
from ecds_lab.errors import EcdsLabError

SUFFIX = ".units.json"


class SidecarError(EcdsLabError, ValueError):
    """A CSV's sidecar is unreadable, malformed or does not match its CSV; the message names it."""


def sidecar_path(csv_path: Path) -> Path:
    """``run.csv`` -> ``run.units.json``."""
    return csv_path.with_name(csv_path.stem + SUFFIX)


@dataclass(frozen=True)
class Sidecar:
    """What an export's sidecar declares about its CSV's rows and the station that measured them."""

    path: Path
    #: direction of approach (+1, -1, 0) of each CSV row, in file order; None when not recorded
    direction: np.ndarray | None
    #: the slide's declared positioning repeatability (1 sigma, m); None when the station declared none
    slide_repeatability_m: float | None
    #: the sensor the run file recorded; None when it recorded none
    sensor: SensorConfig | None

    def columns(self, kept: np.ndarray) -> dict[str, np.ndarray]:
        """The Measurements columns this sidecar supplies for the CSV rows ``kept`` (a mask in file order)."""
        n = int(np.count_nonzero(kept))
        out: dict[str, np.ndarray] = {}
        if self.direction is not None:
            out["direction"] = self.direction[kept]
        if self.slide_repeatability_m is not None:
            out["slide_repeatability_m"] = np.full(n, self.slide_repeatability_m)
        return out


def read_sidecar(csv_path: Path, rows: int | None = None) -> Sidecar | None:
    """The sidecar of ``csv_path`` if there is one; ``rows`` (the CSV's data rows) must match what it declares.

    A sidecar that is unreadable, malformed or written for a different number of rows raises
    SidecarError naming it (the CSV was edited after the export, or the sidecar belongs to another file).
    """
    path = sidecar_path(Path(csv_path))
    if not path.is_file():
        return None
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise SidecarError(f"{path}: cannot read the CSV's sidecar: {exc.strerror or exc}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SidecarError(f"{path}: the CSV's sidecar is not valid JSON ({exc}); delete it to read "
                            f"{Path(csv_path).name} without it") from None
    if not isinstance(doc, dict):
        raise SidecarError(f"{path}: the CSV's sidecar is not a JSON object")
    return Sidecar(path, _directions(path, doc, rows), _repeatability(path, doc), _sensor(path, doc))


def _directions(path: Path, doc: dict[str, Any], rows: int | None) -> np.ndarray | None:
    values = doc.get("direction")
    if values is None:
        return None
    if not isinstance(values, list) or any(v not in (-1, 0, 1) or isinstance(v, bool) for v in values):
        raise SidecarError(f"{path}: 'direction' must be a list of -1, 0 or 1, one per CSV row")
    if rows is not None and len(values) != rows:
        raise SidecarError(f"{path}: declares the direction of {len(values)} rows, but the CSV has {rows}; the "
                            f"CSV was changed after the export (delete the sidecar to read it without)")
    return np.asarray(values, dtype=int)


def _station(doc: dict[str, Any]) -> dict[str, Any]:
    station = doc.get("station")
    return station if isinstance(station, dict) else {}


def _repeatability(path: Path, doc: dict[str, Any]) -> float | None:
    value = _station(doc).get("slide_repeatability_m")
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise SidecarError(f"{path}: station.slide_repeatability_m = {value!r} is not a repeatability in metres "
                            "(a number >= 0)")
    return float(value)


def _sensor(path: Path, doc: dict[str, Any]) -> SensorConfig | None:
    value = _station(doc).get("sensor")
    if value is None:
        return None
    try:
        return SensorConfig.model_validate(value)
    except ValidationError as exc:
        raise SidecarError(f"{path}: station.sensor is not a sensor description: "
                            f"{exc.errors()[0]['loc']}: {exc.errors()[0]['msg']}") from None
