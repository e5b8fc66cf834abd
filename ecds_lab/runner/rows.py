"""One run-file row: a bridge reading with where, when and at what temperatures it was taken."""

from __future__ import annotations

import math

from ecds_lab.data.columns import PLANNED_POINT
from ecds_lab.instruments.interfaces import BridgeReading
from ecds_lab.runner.slide_position import SlidePosition
from ecds_lab.runner.steps import MeasurePoint


def reading_row(*, time_s: float, wall_time_s: float, step_index: int, kind: int, point: MeasurePoint | None,
                position: SlidePosition, in_air: bool, freq_hz: float, temperatures: dict[str, float],
                powers_w: dict[str, float], reading: BridgeReading) -> dict[str, float]:
    """The row for ecds_lab/data/columns.py; ``point`` is the planned point measured (None for a logged reading).

    A coil in air has no target distance: its commanded position is +inf.
    """
    planned = point is not None and kind == PLANNED_POINT
    commanded = math.inf if in_air else (position.x_mm if position.x_mm is not None else math.nan)
    return {
        "time_s": time_s, "wall_time_s": wall_time_s, "step": step_index,
        "point": point.point if planned and point is not None else -1, "kind": kind,
        "sweep": point.sweep if point is not None else -1, "repeat": point.repeat if point is not None else 0,
        "reading": point.reading if point is not None else 0,
        "x_commanded_mm": commanded, "x_readback_mm": position.readback_mm, "direction": position.direction,
        "freq_hz": freq_hz,
        "t_coil_c": temperatures.get("coil", math.nan), "t_target_c": temperatures.get("target", math.nan),
        "t_ambient_c": temperatures.get("ambient", math.nan),
        "target_heater_w": powers_w["target"], "coil_heater_w": powers_w["coil"],
        "ls_h": reading.main, "rs_ohm": reading.secondary,
    }
