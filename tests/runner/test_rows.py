"""A reading's row: every value lands in the column its name says (the row is a tuple in column order)."""

from __future__ import annotations

import math

from ecds_lab.data.columns import COLUMN_NAMES, LOGGED_POINT, PLANNED_POINT
from ecds_lab.instruments.interfaces import BridgeReading
from ecds_lab.runner.rows import reading_row
from ecds_lab.runner.slide_position import SlidePosition
from ecds_lab.runner.steps import MeasurePoint


def placed(x_mm: float | None, readback_mm: float, direction: int) -> SlidePosition:
    position = SlidePosition(slide=None)  # type: ignore[arg-type]  # never moved here
    position.x_mm, position.readback_mm, position.direction = x_mm, readback_mm, direction
    return position


def by_name(row: tuple[float, ...]) -> dict[str, float]:
    assert len(row) == len(COLUMN_NAMES)
    return dict(zip(COLUMN_NAMES, row, strict=True))


def test_a_planned_point_fills_every_column_by_its_name():
    point = MeasurePoint(point=7, x_mm=21.5, freq_hz=500.0, sweep=2, repeat=3, reading=4)
    row = by_name(reading_row(
        time_s=12.5, wall_time_s=1.7e9, step_index=9, kind=PLANNED_POINT, point=point,
        position=placed(21.5, 21.498, -1), in_air=False, freq_hz=500.0,
        temperatures={"coil": 23.1, "target": 24.2, "ambient": 22.3}, powers_w={"target": 1.25, "coil": 0.5},
        reading=BridgeReading(1.23e-4, 4.56, 500.0)))
    assert row == {
        "time_s": 12.5, "wall_time_s": 1.7e9, "step": 9, "point": 7, "kind": PLANNED_POINT, "sweep": 2,
        "repeat": 3, "reading": 4, "x_commanded_mm": 21.5, "x_readback_mm": 21.498, "direction": -1,
        "freq_hz": 500.0, "t_coil_c": 23.1, "t_target_c": 24.2, "t_ambient_c": 22.3, "target_heater_w": 1.25,
        "coil_heater_w": 0.5, "ls_h": 1.23e-4, "rs_ohm": 4.56,
    }


def test_a_logged_reading_in_air_has_no_point_an_infinite_distance_and_nan_for_missing_temperatures():
    row = by_name(reading_row(
        time_s=1.0, wall_time_s=2.0, step_index=3, kind=LOGGED_POINT, point=None,
        position=placed(None, math.nan, 0), in_air=True, freq_hz=15000.0, temperatures={"coil": 40.0},
        powers_w={"target": math.nan, "coil": 2.0}, reading=BridgeReading(1e-4, 2.0, 15000.0)))
    assert (row["point"], row["sweep"], row["repeat"], row["reading"]) == (-1, -1, 0, 0)
    assert row["x_commanded_mm"] == math.inf and row["t_coil_c"] == 40.0
    assert math.isnan(row["t_target_c"]) and math.isnan(row["t_ambient_c"]) and math.isnan(row["target_heater_w"])


def test_an_unknown_position_is_nan_not_the_last_commanded_one():
    row = by_name(reading_row(
        time_s=0.0, wall_time_s=0.0, step_index=0, kind=PLANNED_POINT, point=None,
        position=placed(None, math.nan, 0), in_air=False, freq_hz=500.0, temperatures={},
        powers_w={"target": 0.0, "coil": 0.0}, reading=BridgeReading(1e-4, 1.0, 500.0)))
    assert math.isnan(row["x_commanded_mm"]) and row["point"] == -1
