"""Clocks: wall time for the real lab, simulated time shared by simulators and runner.

Everything that waits (settling, pacing between commands, polling a moving slide)
asks a clock, so a simulated hour of heating passes in well under a second.
"""

from __future__ import annotations

import time
from typing import Protocol


class Clock(Protocol):
    """Time source and sleeper; seconds, monotonic."""

    def now(self) -> float: ...

    def sleep(self, seconds: float) -> None: ...


class WallClock:
    """Real time: what a lab with hardware uses."""

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)


class SimulatedClock:
    """Simulated time that advances only when someone sleeps.

    ``real_time_factor`` = 0 makes every sleep instant; 1 sleeps as long as the
    simulated time passes (for watching a simulated run live); 0.001 makes an hour
    pass in 3.6 s.
    """

    def __init__(self, start: float = 0.0, real_time_factor: float = 0.0) -> None:
        if real_time_factor < 0:
            raise ValueError(f"real_time_factor must be >= 0, got {real_time_factor}")
        self._t = float(start)
        self.real_time_factor = real_time_factor

    def now(self) -> float:
        return self._t

    def sleep(self, seconds: float) -> None:
        if seconds <= 0:
            return
        self._t += seconds
        if self.real_time_factor > 0:
            time.sleep(seconds * self.real_time_factor)

    def advance(self, seconds: float) -> None:
        """Let time pass without the real-time delay (instrument-internal time, e.g. a measurement)."""
        if seconds > 0:
            self._t += seconds
