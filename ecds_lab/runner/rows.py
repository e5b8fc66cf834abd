"""One run-file row: a bridge reading with where, when and at what temperatures it was taken."""

from __future__ import annotations

import math

from ecds_lab.data.columns import PLANNED_POINT
from ecds_lab.instruments.interfaces import BridgeReading
from ecds_lab.runner.slide_position import SlidePosition
from ecds_lab.runner.steps import MeasurePoint


def reading_row(*, time_s: float, wall_time_s: float, step_index: int, kind: int, point: MeasurePoint | None,
                position: SlidePosition, in_air: bool, freq_hz: float, temperatures: dict[str, float],
                powers_w: dict[str, float], reading: BridgeReading) -> tuple[float, ...]:
    """The row in the column order of ecds_lab/data/columns.py (``COLUMN_NAMES``, named beside each value
    below); ``point`` is the planned point measured (None for a logged reading).

    A tuple in column order is what ``RunWriter.append_row`` takes as it is: no names looked up per reading.
    A coil in air has no target distance: its commanded position is +inf.
    """
    planned = point is not None and kind == PLANNED_POINT
    commanded = commanded_mm(position.x_mm, in_air)
    return (
        time_s,  # time_s
        wall_time_s,  # wall_time_s
        step_index,  # step
        point.point if planned and point is not None else -1,  # point
        kind,  # kind
        point.sweep if point is not None else -1,  # sweep
        point.repeat if point is not None else 0,  # repeat
        point.reading if point is not None else 0,  # reading
        commanded,  # x_commanded_mm
        position.readback_mm,  # x_readback_mm
        position.direction,  # direction
        freq_hz,  # freq_hz
        temperatures.get("coil", math.nan),  # t_coil_c
        temperatures.get("target", math.nan),  # t_target_c
        temperatures.get("ambient", math.nan),  # t_ambient_c
        powers_w["target"],  # target_heater_w
        powers_w["coil"],  # coil_heater_w
        reading.main,  # ls_h
        reading.secondary,  # rs_ohm
    )


def commanded_mm(x_mm: float | None, in_air: bool) -> float:
    """The commanded distance a reading is recorded at: +inf with the coil in air, NaN while the slide's position
    is unknown (after homing, before its first move; ``storage.reader.located`` leaves such rows out)."""
    return math.inf if in_air else (x_mm if x_mm is not None else math.nan)
