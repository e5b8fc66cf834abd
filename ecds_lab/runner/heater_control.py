"""Closed-loop heater control: a PI controller on a thermocouple, output as supply volts."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ecds_lab.config.station import LoopGains


@dataclass
class HeaterGoal:
    """What a heater should do: hold a temperature, deliver a power, or stay off."""

    setpoint_c: float | None = None
    power_w: float | None = None

    @property
    def active(self) -> bool:
        return self.setpoint_c is not None or self.power_w is not None


class PowerLoop:
    """PI control of heater power with anti-windup (the integral stops while the output is saturated)."""

    def __init__(self, max_power_w: float, gains: LoopGains) -> None:
        self.max_power_w = max_power_w
        self.kp = gains.kp_w_per_k
        self.ti = gains.ti_s
        self.integral_w = 0.0

    def update(self, setpoint_c: float, measured_c: float, dt_s: float) -> float:
        """The power for this period. The integral moves with the error but only as far as the output stays
        within [0, max] (clamping anti-windup): a large integral step near saturation is cut to the headroom,
        never refused whole, so a loop near full power still reaches its setpoint."""
        error = setpoint_c - measured_c
        proportional = self.kp * error
        candidate = self.integral_w + self.kp * error * dt_s / self.ti
        if error > 0:
            candidate = min(candidate, max(self.integral_w, self.max_power_w - proportional))
        elif error < 0:
            candidate = max(candidate, min(self.integral_w, -proportional))
        self.integral_w = candidate
        return min(max(proportional + self.integral_w, 0.0), self.max_power_w)


def volts_for_power(power_w: float, heater_ohm: float, max_voltage_v: float) -> float:
    """Supply voltage that puts ``power_w`` into a resistive heater, limited to ``max_voltage_v``."""
    return min(math.sqrt(max(power_w, 0.0) * heater_ohm), max_voltage_v)
