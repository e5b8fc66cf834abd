"""The per-point columns of a run file, with their units (the one place they are defined)."""

from __future__ import annotations

from dataclasses import dataclass

#: Row kinds in the ``kind`` column.
PLANNED_POINT = 0
LOGGED_POINT = 1  # a reading taken while waiting for a steady state or during the cool-down


@dataclass(frozen=True)
class Column:
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
