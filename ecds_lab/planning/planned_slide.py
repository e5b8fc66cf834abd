"""The station's slide as a plan will move it, moving nothing: where each move ends and from which side.

It stands in for the slide's driver under the runner's own position bookkeeping (``runner.slide_position``), so
the planned readings carry the commanded distance and direction of approach the run will record: no distance after
homing until the first move, and the side the GRBL driver's ``approach`` option finishes each move from, by the
driver's own rule (``drivers.grbl.approach_waypoints``, clamped to the travel).
"""

from __future__ import annotations

import inspect
from typing import Any

from ecds_lab.config.checks import slide_travel_mm
from ecds_lab.config.station import StationConfig
from ecds_lab.drivers.grbl import approach_waypoints
from ecds_lab.instruments.kinds import kind

#: How far below its origin homing leaves the slide: GRBL's pull-off ($27, 1 mm by default; machine position
#: -$27 after homing, drivers/grbl.py). Any pull-off gives the same directions unless a target lies within it.
PULL_OFF_MM = 1.0


class PlannedSlide:
    """A positioner that only keeps count of where it would be (a ``Positioner`` for ``SlidePosition``)."""

    def __init__(self, station: StationConfig) -> None:
        options = {**_driver_defaults(station), **station.slide.options}
        low, high = slide_travel_mm(station)
        self.min_position_m, self.max_position_m = low * 1e-3, high * 1e-3
        self.travel_mm = (low, high)
        self.origin_mm = float(options.get("origin_mm", high))
        self.approach = str(options.get("approach", "direct"))
        self.overshoot_mm = float(options.get("overshoot_mm", 0.0))
        self._x_mm = self.origin_mm - PULL_OFF_MM
        self._direction = 0

    def identity(self) -> str:
        return "planned slide"

    def home(self) -> None:
        """Pulled off below the origin, no direction known (the driver's homing forgets it too)."""
        self._x_mm, self._direction = self.origin_mm - PULL_OFF_MM, 0

    def move_to(self, position_m: float, speed_m_per_s: float | None = None) -> int:
        """The direction of the final approach of a move to ``position_m``, as the driver would make it."""
        target = round(float(position_m) * 1e3, 6)
        for waypoint in approach_waypoints(self._x_mm, target, self._direction, self.approach, self.overshoot_mm,
                                           self.travel_mm):
            self._direction = 1 if waypoint > self._x_mm else -1
            self._x_mm = waypoint
        return self._direction

    def position_m(self) -> float:
        return self._x_mm * 1e-3

    def stop(self) -> None:
        """Nothing moves."""


def _driver_defaults(station: StationConfig) -> dict[str, Any]:
    """The slide driver's own defaults of its options (origin, approach, overshoot), as its constructor declares."""
    parameters = inspect.signature(kind(station.slide.driver).driver_class()).parameters
    return {name: p.default for name, p in parameters.items() if p.default is not inspect.Parameter.empty}
