"""Measurements: the bridge readings as columns of numbers in SI, from a run file or a CSV.

The CSV import format:
``time_s,x_mm,freq_hz,t_coil_c,t_target_c,ls_h,rs_ohm`` (``x_mm = inf``: coil in air; ``x_mm = nan``: a
reading taken before the slide had a position, kept in the file but not analysed, as in a run file).
Derived inputs the model parts need (direction of approach, coil temperature rate) are computed here
from the columns, unless the CSV's export sidecar (data/sidecar.py) records them with the station's
figures, so an exported CSV is analysed exactly as its run file.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from pathlib import Path
from typing import TextIO

import numpy as np

from ecds_lab.data.sidecar import read_sidecar
from ecds_lab.errors import EcdsLabError

#: Marks a derived column the caller did not give (computed in ``__post_init__``).
_NOT_GIVEN = np.zeros(0)

CSV_COLUMNS = ("time_s", "x_mm", "freq_hz", "t_coil_c", "t_target_c", "ls_h", "rs_ohm")


class DataError(EcdsLabError, ValueError):
    """Input data are malformed; the message names the file, row and column."""


@dataclass
class Measurements:
    """One row per bridge reading, SI units; rows in time order within each segment.

    ``segment`` numbers independent recordings (runs or files): time may restart
    between segments, and history-dependent effects restart with them.
    """

    time_s: np.ndarray
    x_m: np.ndarray
    freq_hz: np.ndarray
    t_coil_c: np.ndarray
    t_target_c: np.ndarray
    ls_h: np.ndarray
    rs_ohm: np.ndarray
    #: derived from the time column (a new segment where time runs backwards) when not given
    segment: np.ndarray = field(default_factory=lambda: _NOT_GIVEN)
    #: the distance column when not given
    x_commanded_m: np.ndarray = field(default_factory=lambda: _NOT_GIVEN)
    #: derived from the commanded distances when not given
    direction: np.ndarray = field(default_factory=lambda: _NOT_GIVEN)
    #: the slide's declared positioning repeatability (1 sigma, m) per reading, from the station of the
    #: run file it came from; 0 when unknown (CSV, older files)
    slide_repeatability_m: np.ndarray = field(default_factory=lambda: _NOT_GIVEN)
    source: str = ""

    def __post_init__(self) -> None:
        n = len(self.time_s)
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name != "source" and value is not _NOT_GIVEN:
                setattr(self, f.name, np.asarray(value, dtype=float if f.name not in ("segment", "direction") else int))
        if self.segment is _NOT_GIVEN:
            self.segment = _segments_from_time(self.time_s)
        if self.x_commanded_m is _NOT_GIVEN:
            self.x_commanded_m = self.x_m.copy()
        if self.direction is _NOT_GIVEN:
            self.direction = approach_direction(self.x_commanded_m, self.segment)
        if self.slide_repeatability_m is _NOT_GIVEN:
            self.slide_repeatability_m = np.zeros(n)
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray) and len(value) != n:
                raise DataError(f"{self.source or 'data'}: column {f.name} has {len(value)} rows, expected {n}")

    def __len__(self) -> int:
        return len(self.time_s)

    @property
    def x_mm(self) -> np.ndarray:
        return self.x_m * 1e3

    @property
    def in_air(self) -> np.ndarray:
        return ~np.isfinite(self.x_m)

    @property
    def frequencies_hz(self) -> np.ndarray:
        return np.unique(self.freq_hz)

    def select(self, mask: np.ndarray) -> Measurements:
        """The rows where ``mask`` is true (or the given indices)."""
        return replace(self, **{f.name: getattr(self, f.name)[mask] for f in fields(self)
                                if isinstance(getattr(self, f.name), np.ndarray)})

    @cached_property
    def segment_rows(self) -> list[np.ndarray]:
        """Row indices of each segment in time order (for quantities with a memory)."""
        rows = []
        for segment in np.unique(self.segment):
            index = np.flatnonzero(self.segment == segment)
            rows.append(index[np.argsort(self.time_s[index], kind="stable")])
        return rows

    def coil_temperature_rate_k_per_s(self) -> np.ndarray:
        """d(t_coil)/dt per segment, from a centred difference over roughly a minute of data."""
        return _rate(self.time_s, self.t_coil_c, self.segment)

    @classmethod
    def concatenate(cls, parts: list[Measurements]) -> Measurements:
        """Join recordings; each keeps its own segment numbers, offset to stay distinct."""
        if not parts:
            raise DataError("no measurements to join")
        offset, columns = 0, dict[str, list[np.ndarray]]()
        for part in parts:
            for f in fields(cls):
                value = getattr(part, f.name)
                if isinstance(value, np.ndarray):
                    columns.setdefault(f.name, []).append(value + offset if f.name == "segment" else value)
            offset += int(part.segment.max()) + 1 if len(part) else 0
        merged = {name: np.concatenate(values) for name, values in columns.items()}
        return cls(**merged, source=", ".join(p.source for p in parts))

    # -- CSV ---------------------------------------------------------------------------------
    @classmethod
    def from_csv(cls, path: str | Path) -> Measurements:
        """Read the CSV import format (UTF-8, with or without a BOM); a malformed file fails naming row and column."""
        path = Path(path)
        try:
            handle = path.open(newline="", encoding="utf-8-sig")  # -sig: Excel's CSV starts with a BOM
        except OSError as exc:
            raise DataError(f"{path}: cannot read: {exc.strerror}") from exc
        with handle:
            data = _csv_table(path, handle)
        if not len(data):
            raise DataError(f"{path}: no data rows")
        sidecar = read_sidecar(path, len(data))
        positioned = ~np.isnan(data[:, 1])  # x_mm = nan: a reading before the slide had a position (unused,
        if not positioned.any():            # as in the run file)
            raise DataError(f"{path}: no row has a position (x_mm is nan in every row)")
        data = data[positioned]
        return cls(time_s=data[:, 0], x_m=data[:, 1] * 1e-3, freq_hz=data[:, 2], t_coil_c=data[:, 3],
                   t_target_c=data[:, 4], ls_h=data[:, 5], rs_ohm=data[:, 6], source=str(path),
                   **(sidecar.columns(positioned) if sidecar is not None else {}))

    def to_csv(self, path: str | Path) -> None:
        """Write the CSV import format: every value exactly, x rounded to 1 pm.

        The rounding makes 26 mm read 26.0, not 26.000000000000004.
        """
        columns = [self.time_s, np.round(self.x_mm, 9), self.freq_hz, self.t_coil_c, self.t_target_c, self.ls_h,
                   self.rs_ohm]
        with Path(path).open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(CSV_COLUMNS)
            for row in zip(*columns, strict=True):
                writer.writerow([repr(float(v)) if math.isfinite(v) else "inf" for v in row])


def _csv_table(path: Path, handle: TextIO) -> np.ndarray:
    """The import-format columns (rows x 7) of every non-empty row: read in one vectorised pass (numpy's
    parser, no Python per row); a file it cannot take whole, or with a value not allowed, is read again
    row by row (``_csv_rows``), which names the row and column at fault."""
    try:
        header = [h.strip() for h in next(csv.reader([handle.readline()]), [])]
        if all(c in header for c in CSV_COLUMNS):
            table = np.loadtxt(handle, delimiter=",", usecols=[header.index(c) for c in CSV_COLUMNS], dtype=float,
                               comments=None, quotechar='"', ndmin=2)
            x = CSV_COLUMNS.index("x_mm")
            others = np.delete(table, x, axis=1)
            if not np.isfinite(others).all():  # x_mm may be inf (in air) or nan (no position yet)
                raise ValueError("a value that is not allowed")
            return table
    except (ValueError, UnicodeDecodeError):
        pass
    handle.seek(0)
    rows = _csv_rows(path, handle)
    return np.array(rows, dtype=float).reshape(-1, len(CSV_COLUMNS))


def _csv_rows(path: Path, handle: TextIO) -> list[list[float]]:
    """The import-format columns of every non-empty row, as numbers; errors name row and column."""
    try:
        reader = csv.reader(handle)
        header = [h.strip() for h in next(reader, [])]
        missing = [c for c in CSV_COLUMNS if c not in header]
        if missing:
            raise DataError(f"{path}: header must contain {','.join(CSV_COLUMNS)}; missing {', '.join(missing)}")
        index = [header.index(c) for c in CSV_COLUMNS]
        rows = []
        for line_number, row in enumerate(reader, start=2):
            if not row or all(not cell.strip() for cell in row):
                continue
            values = []
            for column, i in zip(CSV_COLUMNS, index, strict=True):
                try:
                    values.append(float(row[i]))
                except (IndexError, ValueError):
                    cell = row[i] if i < len(row) else "<missing>"
                    raise DataError(f"{path}: row {line_number}, column {column}: {cell!r} is not a number") from None
                if column != "x_mm" and not math.isfinite(values[-1]):  # x_mm: inf in air, nan unknown
                    raise DataError(f"{path}: row {line_number}, column {column}: {row[i]!r} is not allowed")
            rows.append(values)
    except UnicodeDecodeError as exc:
        raise DataError(f"{path}: not a text file (byte {exc.start} is not UTF-8), so not a CSV in the import format"
                        ) from None
    return rows


def approach_direction(x_m: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """+1 / -1: the sign of the last change of commanded x before each row (0 before any move or in air).

    Vectorised: the rows with a distance, segment by segment in row order; each takes the sign of the last
    change at or before it within its segment (a running maximum of the rows where x changed)."""
    x_m, segment = np.asarray(x_m, float), np.asarray(segment)
    direction = np.zeros(len(x_m), dtype=int)
    rows = np.flatnonzero(np.isfinite(x_m))
    rows = rows[np.argsort(segment[rows], kind="stable")]
    if len(rows):
        x, seg = x_m[rows], segment[rows]
        new = np.concatenate([[True], seg[1:] != seg[:-1]])
        change = np.sign(np.diff(x, prepend=x[0])).astype(int)
        change[new] = 0
        index = np.arange(len(rows))
        last = np.maximum.accumulate(np.where(change != 0, index, -1))
        start = np.maximum.accumulate(np.where(new, index, 0))
        direction[rows] = np.where(last >= start, change[np.maximum(last, 0)], 0)
    return _fill_first_direction(direction, x_m, segment)


def _fill_first_direction(direction: np.ndarray, x_m: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """Rows before the first move of a segment take the direction of that segment's first move."""
    for seg in np.unique(segment):
        rows = np.flatnonzero((segment == seg) & np.isfinite(x_m))
        moved = rows[direction[rows] != 0]
        if len(moved):
            first = moved[0]
            direction[rows[(rows < first) & (direction[rows] == 0)]] = direction[first]
    return direction


def _segments_from_time(time_s: np.ndarray) -> np.ndarray:
    """A new segment wherever time runs backwards (files or runs joined one after another)."""
    steps = np.diff(np.asarray(time_s, float), prepend=-np.inf)
    return np.cumsum(steps < 0).astype(int)


def _rate(time_s: np.ndarray, values: np.ndarray, segment: np.ndarray, window_s: float = 60.0) -> np.ndarray:
    """d(values)/dt per segment over at least ``window_s``: from the last reading before t - w/2
    to the first after t + w/2, so sparse readings still get a rate from their neighbours."""
    rate = np.zeros(len(time_s))
    for seg in np.unique(segment):
        rows = np.flatnonzero(segment == seg)
        rows = rows[np.argsort(time_s[rows], kind="stable")]
        t, v = time_s[rows], values[rows]
        if len(rows) < 2:
            continue
        lo = np.clip(np.searchsorted(t, t - window_s / 2, side="right") - 1, 0, len(t) - 1)
        hi = np.clip(np.searchsorted(t, t + window_s / 2, side="left"), 0, len(t) - 1)
        span = t[hi] - t[lo]
        ok = span > 0
        rate[rows[ok]] = (v[hi] - v[lo])[ok] / span[ok]
    return rate
