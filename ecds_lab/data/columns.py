"""The recorded variables with their units, the one place they are defined.

``COLUMNS``: the per-point columns of a run file (HDF5 units attributes come from here).
``VARIABLES``: the variables of the measurements that residuals are examined against and plots
label, recorded or derived; a recorded one takes its unit from its column.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ecds_lab.data.measurements import Measurements

#: Row kinds in the ``kind`` column.
PLANNED_POINT = 0
LOGGED_POINT = 1  # a reading taken while waiting for a steady state or during the cool-down


@dataclass(frozen=True)
class Column:
    """One column of a run file's points table."""

    name: str
    unit: str
    description: str


COLUMNS: tuple[Column, ...] = (
    Column("time_s", "s", "time since the run started (continues across --resume)"),
    Column("wall_time_s", "s", "Unix time of the reading"),
    Column("step", "", "index of the plan step that took the reading"),
    Column("point", "", "planned point number, -1 for logged readings"),
    Column("kind", "", "0 planned point, 1 logged during a ramp or cool-down"),
    Column("sweep", "", "number of the sweep pass (forward and backward passes count separately)"),
    Column("repeat", "", "repeat number of the sweep"),
    Column("reading", "", "reading number at the same position and frequency"),
    Column("x_commanded_mm", "mm", "commanded coil-target distance; inf: coil in air"),
    Column("x_readback_mm", "mm", "distance the slide controller reports after the move"),
    Column("direction", "", "direction of the final approach: +1 increasing x, -1 decreasing, 0 unknown"),
    Column("freq_hz", "Hz", "bridge test frequency"),
    Column("t_coil_c", "degC", "coil (former) thermocouple"),
    Column("t_target_c", "degC", "target thermocouple"),
    Column("t_ambient_c", "degC", "ambient thermocouple"),
    Column("target_heater_w", "W", "target heater power (measured V*I)"),
    Column("coil_heater_w", "W", "thermal-box heater power (measured V*I)"),
    Column("ls_h", "H", "bridge main value: inductance (L-R function)"),
    Column("rs_ohm", "Ohm", "bridge secondary value: resistance (L-R function)"),
)
COLUMN_NAMES = tuple(c.name for c in COLUMNS)
INDEX = {name: i for i, name in enumerate(COLUMN_NAMES)}
UNITS = {c.name: c.unit for c in COLUMNS}


@dataclass(frozen=True)
class Variable:
    """A variable of the measurements: how to get it (units of the CSV), and how a plot labels it."""

    name: str
    unit: str
    label: str
    values: Callable[[Measurements], np.ndarray]
    categorical: bool = False
    display_factor: float = 1.0

    def display(self, data: Measurements) -> np.ndarray:
        """The values in the unit of ``label`` (e.g. time in hours)."""
        return self.values(data) * self.display_factor


VARIABLES: dict[str, Variable] = {v.name: v for v in (
    Variable("x_mm", UNITS["x_commanded_mm"], "distance x (mm)",
             lambda d: np.where(np.isfinite(d.x_m), d.x_mm, np.nan)),
    Variable("freq_hz", UNITS["freq_hz"], "frequency (Hz)", lambda d: d.freq_hz, categorical=True),
    Variable("t_coil_c", UNITS["t_coil_c"], "coil temperature (°C)", lambda d: d.t_coil_c),
    Variable("t_target_c", UNITS["t_target_c"], "target temperature (°C)", lambda d: d.t_target_c),
    Variable("time_s", UNITS["time_s"], "time in run (h)", lambda d: d.time_s, display_factor=1 / 3600.0),
    Variable("direction", UNITS["direction"], "direction of approach",
             lambda d: np.where(np.isfinite(d.x_m), d.direction, np.nan).astype(float), categorical=True),
    Variable("coil_rate_k_per_min", "K/min", "coil temperature rate (K/min)",
             lambda d: d.coil_temperature_rate_k_per_s() * 60.0),
)}
