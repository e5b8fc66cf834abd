"""The NeXus view of a run file: NXdata and NXlog groups a generic viewer plots, live and after a kill.

Every NXdata field and NXlog field is an HDF5 *virtual dataset* onto a column of the live
``/entry/points`` table, mapped with an unlimited selection: it grows with the table, costs
nothing per point, and a SWMR reader (or a viewer opening a killed run's file) sees every row
flushed so far. One exception: a spectroscopy run's |Z| is not a column, so it is written live
beside the table (a spectrum has tens of points, not thousands).

The root ``@default`` leads to ``/entry`` and its ``@default`` to a plot that suits the run kind:
  displacement sweep   Ls against x, one NXdata per frequency (the default: the first frequency)
  coil/target heating  Ls against time, temperatures in their own NXdata
  spectroscopy         |Z| against frequency
A sweep's rows come x by x, each position giving ``readings`` rows per frequency in plan order,
so the rows of one frequency are a regular strided block selection of the table. A heating run's
rows mix frequencies irregularly (logged readings, readings in place, sweeps), so its per-frequency
Ls(t) series are written live too: a heating run writes a row every few seconds at most.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone

import h5py
import numpy as np

from ecds_lab.data.columns import COLUMNS, INDEX

_UNLIMITED = h5py.h5s.UNLIMITED
_LIVE_CHUNK = 1024
_TEMPERATURES = ("t_coil_c", "t_target_c", "t_ambient_c")
_SHAPED_KINDS = ("displacement_sweep", "coil_heating", "target_heating")


@dataclass(frozen=True)
class RowPattern:
    """Which table rows a field takes: ``block`` rows every ``stride`` rows from ``start``."""

    start: int = 0
    stride: int = 1
    block: int = 1


ALL_ROWS = RowPattern()


@dataclass(frozen=True)
class SweepShape:
    """What the layout needs of the recorded experiment: the frequencies it measures at, in plan order,
    and for a displacement sweep the readings per point (which fix its row order)."""

    frequencies_hz: tuple[float, ...]
    readings_per_point: int = 1

    def rows_of(self, index: int) -> RowPattern:
        """The rows measured at the ``index``-th frequency."""
        per_position = len(self.frequencies_hz) * self.readings_per_point
        return RowPattern(index * self.readings_per_point, per_position, self.readings_per_point)


def now_iso() -> str:
    """The time of day as NeXus wants it (ISO 8601 with time zone)."""
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def column_view(group: h5py.Group, name: str, table: h5py.Dataset, column: str,
                rows: RowPattern = ALL_ROWS) -> h5py.Dataset:
    """A 1-D virtual dataset ``group/name`` showing ``column`` of ``table`` at ``rows``, growing with it."""
    width = table.shape[1]
    source = h5py.h5s.create_simple((0, width), (_UNLIMITED, width))
    source.select_hyperslab((rows.start, INDEX[column]), (_UNLIMITED, 1), (rows.stride, 1), (rows.block, 1))
    view = h5py.h5s.create_simple((0,), (_UNLIMITED,))
    view.select_hyperslab((0,), (_UNLIMITED,), (rows.block,), (rows.block,))
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_fill_value(np.array(math.nan))
    dcpl.set_virtual(view, b".", table.name.encode(), source)
    h5py.h5d.create(group.id, name.encode(), h5py.h5t.IEEE_F64LE, h5py.h5s.create_simple((0,), (_UNLIMITED,)),
                    dcpl=dcpl)
    dataset = group[name]
    unit = next(c for c in COLUMNS if c.name == column)
    dataset.attrs.update({"units": unit.unit, "long_name": f"{column} ({unit.unit})" if unit.unit else column})
    return dataset


def _nxdata(parent: h5py.Group, name: str, signal: str, axis: str, **more: object) -> h5py.Group:
    group = parent.create_group(name)
    group.attrs.update({"NX_class": "NXdata", "signal": signal, "axes": [axis], f"{axis}_indices": 0, **more})
    return group


class NexusLayout:
    """Creates the plottable groups of a new run file and keeps the live-written ones up to date."""

    def __init__(self, root: h5py.File, table: h5py.Dataset, kind: str, sweep: SweepShape | None) -> None:
        self._spectrum: list[h5py.Dataset] = []
        self._series: list[tuple[float, list[h5py.Dataset]]] = []
        entry = root["entry"]
        root.attrs.update({"NX_class": "NXroot", "default": "entry"})
        entry.create_dataset("start_time", data=entry.attrs.get("start_time") or now_iso())
        data = _nxdata(entry, "data", "ls_h", "x_commanded_mm")
        for column in COLUMNS:
            column_view(data, column.name, table, column.name).attrs["long_name"] = column.description
        logs = entry.require_group("instrument").require_group("thermocouples")
        logs.attrs["NX_class"] = "NXcollection"
        for name in ("coil", "target", "ambient"):
            log = logs.create_group(name)
            log.attrs["NX_class"] = "NXlog"
            column_view(log, "time", table, "time_s")
            column_view(log, "value", table, f"t_{name}_c")
        entry.attrs["default"] = self._plots(entry, table, kind, sweep)

    def _plots(self, entry: h5py.Group, table: h5py.Dataset, kind: str, sweep: SweepShape | None) -> str:
        """Create the kind's NXdata groups; return the name of the default one."""
        if kind == "displacement_sweep" and sweep is not None:
            names = []
            for i, freq in enumerate(sweep.frequencies_hz):
                name = f"ls_vs_x_{freq:g}_hz"
                rows = sweep.rows_of(i)
                group = _nxdata(entry, name, "ls_h", "x_commanded_mm", title=f"Ls against x at {freq:g} Hz")
                column_view(group, "ls_h", table, "ls_h", rows)
                column_view(group, "x_commanded_mm", table, "x_commanded_mm", rows)
                names.append(name)
            return names[0]
        if kind in ("coil_heating", "target_heating"):
            temperatures = _nxdata(entry, "temperatures_vs_time", "t_coil_c", "time_s",
                                   auxiliary_signals=list(_TEMPERATURES[1:]), title="temperatures against time")
            for column in (*_TEMPERATURES, "time_s"):
                column_view(temperatures, column, table, column)
            if sweep is None:
                ls = _nxdata(entry, "ls_vs_time", "ls_h", "time_s", title="Ls against time, all frequencies")
                for column in ("ls_h", "time_s"):
                    column_view(ls, column, table, column)
                return "ls_vs_time"
            names = []
            for freq in sweep.frequencies_hz:
                name = f"ls_vs_time_{freq:g}_hz"
                group = _nxdata(entry, name, "ls_h", "time_s", auxiliary_signals=["t_coil_c", "t_target_c"],
                                title=f"Ls against time at {freq:g} Hz")
                self._series.append((freq, [self._live_field(group, column) for column in
                                            ("ls_h", "time_s", "t_coil_c", "t_target_c")]))
                names.append(name)
            return names[0]
        if kind == "spectroscopy":
            group = _nxdata(entry, "impedance_vs_frequency", "z_abs_ohm", "freq_hz", title="|Z| against frequency")
            self._spectrum = [self._live_field(group, "z_abs_ohm", "Ohm"), self._live_field(group, "freq_hz")]
            return "impedance_vs_frequency"
        return "data"

    @staticmethod
    def _live_field(group: h5py.Group, name: str, unit: str | None = None) -> h5py.Dataset:
        field = group.create_dataset(name, shape=(0,), maxshape=(None,), dtype="<f8", chunks=(_LIVE_CHUNK,))
        field.attrs["units"] = unit if unit is not None else next(c.unit for c in COLUMNS if c.name == name)
        return field

    def rows_written(self, rows: Sequence[Sequence[float]] | np.ndarray) -> None:
        """Extend the live-written fields by the rows just appended to the table (heating, spectroscopy)."""
        if not self._series and not self._spectrum:
            return
        rows = np.asarray(rows, dtype=float)
        freq = rows[:, INDEX["freq_hz"]]
        if self._spectrum:
            z = np.hypot(rows[:, INDEX["rs_ohm"]], 2 * np.pi * freq * rows[:, INDEX["ls_h"]])
            for field, values in zip(self._spectrum, (z, freq), strict=True):
                _extend(field, values)
        for series_freq, fields in self._series:
            mine = rows[freq == series_freq]
            if len(mine):
                for field in fields:
                    _extend(field, mine[:, INDEX[field.name.rsplit("/", 1)[1]]])


def _extend(field: h5py.Dataset, values: np.ndarray) -> None:
    n = field.shape[0]
    field.resize((n + len(values),))
    field[n:] = values
    field.flush()


def finish(entry: h5py.Group) -> None:
    """Record ``end_time`` as an NXentry field (the file is open for writing again, SWMR over)."""
    if "end_time" in entry:
        del entry["end_time"]
    entry.create_dataset("end_time", data=entry.attrs.get("end_time") or now_iso())


def sweep_shape(metadata: Mapping[str, str]) -> SweepShape | None:
    """The frequencies (and a sweep's readings per point) of the experiment YAML a run file records."""
    if metadata.get("kind") not in _SHAPED_KINDS or not metadata.get("experiment_yaml"):
        return None
    from ecds_lab.config.experiment import EXPERIMENT_ADAPTER
    from ecds_lab.config.loading import parse_yaml, validate

    try:
        experiment = validate("run metadata", parse_yaml(metadata["experiment_yaml"], "run metadata"),
                              EXPERIMENT_ADAPTER)
    except Exception:  # a writer given odd metadata still writes a valid file, just without per-frequency plots
        return None
    sweep = getattr(experiment, "sweep", None)
    heating = getattr(experiment, "heating", None)
    frequencies = [*getattr(experiment, "frequencies_hz", []), *(sweep.frequencies_hz if sweep else []),
                   *(getattr(heating, "log_frequencies_hz", None) or [])]
    readings = sweep.readings_per_point if sweep is not None else 1
    return SweepShape(tuple(dict.fromkeys(float(f) for f in frequencies)), readings)
