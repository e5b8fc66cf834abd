"""Thermocouple readings under interlock: over-temperature, or a thermocouple lost while heating, stops the run."""

from __future__ import annotations

import math
from collections.abc import Callable

from ecds_lab.clock import Clock
from ecds_lab.errors import InstrumentError, SafetyInterlock, TransportError
from ecds_lab.instruments.interfaces import TemperatureScanner


class GuardedThermocouples:
    """Reads the scanner (again once the last reading is ``max_age_s`` old, or when asked fresh) and
    enforces the limits.

    A SafetyInterlock propagates to the runner, whose safe state switches the heater off.
    """

    def __init__(self, scanner: TemperatureScanner, clock: Clock, max_temperature_c: dict[str, float],
                 heating: Callable[[], bool], max_age_s: float) -> None:
        self.scanner = scanner
        self.clock = clock
        self.max_temperature_c = max_temperature_c
        self.heating = heating
        self.max_age_s = max_age_s
        self.latest: dict[str, float] = {}
        self._read_at = -math.inf

    def read(self, fresh: bool = False) -> dict[str, float]:
        """Temperatures by thermocouple name (C); raises SafetyInterlock if one is over its limit."""
        if not fresh and self.clock.now() - self._read_at < self.max_age_s:
            return self.latest
        try:
            temperatures = self.scanner.read_temperatures_c()
        except (InstrumentError, TransportError) as exc:
            if self.heating():
                raise SafetyInterlock(f"thermocouple lost while heating, heater switched off: {exc}") from exc
            raise
        limits = self.max_temperature_c
        for name, value in temperatures.items():
            if name in limits and value > limits[name]:
                raise SafetyInterlock(f"{name} thermocouple reads {value:.1f} C, above the {limits[name]:g} C limit;"
                                      " heater switched off")
        self.latest, self._read_at = temperatures, self.clock.now()
        return temperatures
