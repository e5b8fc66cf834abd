"""How well a heater held its setpoint while readings were taken there: the thermocouple's range, drift and
largest deviation over the hold, judged against the experiment's tolerance."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

#: The unit of each field of a HoldRecord, recorded beside them in the run file.
HOLD_UNITS = {"heater": "", "setpoint_c": "degC", "tolerance_k": "K", "start_s": "s", "end_s": "s",
              "samples": "", "t_first_c": "degC", "t_last_c": "degC", "t_min_c": "degC", "t_max_c": "degC",
              "drift_k": "K", "max_deviation_k": "K", "within_tolerance": ""}


@dataclass(frozen=True)
class HoldRecord:
    """One hold at a setpoint: the controlled thermocouple from the first to the last reading of the hold."""

    heater: str
    setpoint_c: float
    tolerance_k: float
    start_s: float
    end_s: float
    samples: int
    t_first_c: float
    t_last_c: float
    t_min_c: float
    t_max_c: float
    drift_k: float
    max_deviation_k: float
    within_tolerance: bool

    def describe(self) -> str:
        verdict = "within" if self.within_tolerance else "OUT OF"
        return (f"{self.heater} held at {self.setpoint_c:g} C: {self.t_min_c:.2f} to {self.t_max_c:.2f} C over "
                f"{self.end_s - self.start_s:.0f} s (drift {self.drift_k:+.2f} K, largest deviation "
                f"{self.max_deviation_k:.2f} K), {verdict} the {self.tolerance_k:g} K tolerance")

    def as_dict(self) -> dict[str, float | str | bool | int]:
        return asdict(self)


class HoldTracker:
    """Follows one heater's thermocouple from the moment it is steady at a setpoint until the hold is closed."""

    def __init__(self, heater: str, setpoint_c: float, tolerance_k: float) -> None:
        self.heater = heater
        self.setpoint_c = setpoint_c
        self.tolerance_k = tolerance_k
        self._first: tuple[float, float] | None = None
        self._last: tuple[float, float] = (math.nan, math.nan)
        self._min, self._max, self._count = math.inf, -math.inf, 0

    def observe(self, time_s: float, temperatures: dict[str, float]) -> None:
        value = temperatures.get(self.heater, math.nan)
        if not math.isfinite(value):
            return
        if self._first is None:
            self._first = (time_s, value)
        self._last = (time_s, value)
        self._min, self._max, self._count = min(self._min, value), max(self._max, value), self._count + 1

    def close(self) -> HoldRecord:
        first = self._first or self._last
        deviation = max(abs(self._min - self.setpoint_c), abs(self._max - self.setpoint_c)) if self._count else math.nan
        return HoldRecord(self.heater, self.setpoint_c, self.tolerance_k, first[0], self._last[0], self._count,
                          first[1], self._last[1], self._min if self._count else math.nan,
                          self._max if self._count else math.nan, self._last[1] - first[1], deviation,
                          bool(self._count) and deviation <= self.tolerance_k)
