"""Closed-loop heater control: a PI controller on a thermocouple, output as supply volts."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class HeaterGoal:
    """What a heater should do: hold a temperature, deliver a power, or stay off."""

    setpoint_c: float | None = None
    power_w: float | None = None

    @property
    def active(self) -> bool:
        return self.setpoint_c is not None or self.power_w is not None


class PowerLoop:
    """PI control of heater power with anti-windup; gains suit plates and boxes of minutes' time constant."""

    def __init__(self, max_power_w: float, kp_w_per_k: float = 3.0, ti_s: float = 400.0) -> None:
        self.max_power_w = max_power_w
        self.kp = kp_w_per_k
        self.ti = ti_s
        self.integral_w = 0.0

    def update(self, setpoint_c: float, measured_c: float, dt_s: float) -> float:
        error = setpoint_c - measured_c
        proportional = self.kp * error
        candidate = self.integral_w + self.kp * error * dt_s / self.ti
        power = proportional + candidate
        if 0.0 < power < self.max_power_w or (power >= self.max_power_w and error < 0) or (power <= 0 and error > 0):
            self.integral_w = candidate
        return min(max(proportional + self.integral_w, 0.0), self.max_power_w)


def volts_for_power(power_w: float, heater_ohm: float, max_voltage_v: float) -> float:
    """Supply voltage that puts ``power_w`` into a resistive heater, limited to ``max_voltage_v``."""
    return min(math.sqrt(max(power_w, 0.0) * heater_ohm), max_voltage_v)
