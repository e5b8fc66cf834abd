"""Where the runner put the slide: commanded position, read-back, and the direction of the last move."""

from __future__ import annotations

import math

from ecds_lab.instruments.interfaces import Positioner


class SlidePosition:
    """Moves the slide in millimetres and remembers where it is (``x_mm`` None: unknown, e.g. after homing)."""

    def __init__(self, slide: Positioner) -> None:
        self.slide = slide
        self.x_mm: float | None = None
        self.readback_mm = math.nan
        self.direction = 0

    def home(self) -> None:
        self.slide.home()
        self.x_mm = None

    def move_to(self, x_mm: float) -> bool:
        """Move unless already there; True if the slide moved."""
        if self.x_mm == x_mm:
            return False
        self.direction = self.slide.move_to(x_mm * 1e-3)
        self.readback_mm = self.slide.position_m() * 1e3
        self.x_mm = x_mm
        return True
