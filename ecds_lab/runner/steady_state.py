"""What "steady" means for a heated thermocouple: the criterion as a value, and the window that tests it."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass


def _duration(seconds: float) -> str:
    """A duration the way an operator reads it: 90 s, 5 min, 6 h."""
    if seconds >= 3600.0 and seconds % 3600.0 == 0.0:
        return f"{seconds / 3600.0:g} h"
    if seconds >= 60.0 and seconds % 60.0 == 0.0:
        return f"{seconds / 60.0:g} min"
    return f"{seconds:g} s"


@dataclass(frozen=True)
class SteadyState:
    """Steady when a straight-line fit over ``window_s`` has a slope below ``slope_k_per_min`` and the
    reading is within ``tolerance_k`` of the setpoint; checked every ``check_interval_s``.
    ``timeout_s`` None means wait without limit."""

    slope_k_per_min: float
    window_s: float
    tolerance_k: float
    check_interval_s: float
    timeout_s: float | None = None

    def __post_init__(self) -> None:
        for name in ("slope_k_per_min", "window_s", "tolerance_k", "check_interval_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"SteadyState.{name} must be > 0, got {getattr(self, name)!r}")
        if self.timeout_s is not None and not self.timeout_s > 0:
            raise ValueError(f"SteadyState.timeout_s must be > 0 or None (no limit), got {self.timeout_s!r}")

    def describe(self) -> str:
        limit = "no time limit" if self.timeout_s is None else f"give up after {_duration(self.timeout_s)}"
        return (f"< {self.slope_k_per_min:g} K/min over {_duration(self.window_s)}, within {self.tolerance_k:g} K, "
                f"checked every {_duration(self.check_interval_s)}, {limit}")


class SteadinessWindow:
    """The recent readings of one thermocouple, enough to judge a SteadyState at a setpoint."""

    def __init__(self, criterion: SteadyState, setpoint_c: float) -> None:
        self.criterion = criterion
        self.setpoint_c = setpoint_c
        self._readings: deque[tuple[float, float]] = deque()

    def add(self, time_s: float, value_c: float) -> bool:
        """Take a reading; True once the thermocouple is steady and near the setpoint."""
        window = self._readings
        window.append((time_s, value_c))
        while len(window) > 1 and window[1][0] <= time_s - self.criterion.window_s:
            window.popleft()  # keep one reading at or before the window's start: it spans the window
        return self._slope_is_small() and abs(value_c - self.setpoint_c) <= self.criterion.tolerance_k

    def _slope_is_small(self) -> bool:
        """Slope of a straight-line fit over a full window below the threshold."""
        window = self._readings
        if len(window) < 3 or window[-1][0] - window[0][0] < self.criterion.window_s:
            return False
        n = len(window)
        mean_t = sum(t for t, _ in window) / n
        mean_v = sum(v for _, v in window) / n
        sxx = sum((t - mean_t) ** 2 for t, _ in window)
        slope = sum((t - mean_t) * (v - mean_v) for t, v in window) / sxx
        return abs(slope) * 60.0 <= self.criterion.slope_k_per_min
