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


#: The derivative is filtered with a time constant of Td / this (a common choice, 8-20).
DERIVATIVE_FILTER = 8.0


class PowerLoop:
    """PI(D) control of heater power: the derivative acts on the measurement (a setpoint change gives no kick)
    through a first-order filter; the integral is clamped at the output's headroom (anti-windup)."""

    def __init__(self, max_power_w: float, gains: LoopGains) -> None:
        self.max_power_w = max_power_w
        self.kp = gains.kp_w_per_k
        self.ti = gains.ti_s
        self.td = gains.td_s
        self.integral_w = 0.0
        self.derivative_w = 0.0
        self._last_measured_c: float | None = None

    def update(self, setpoint_c: float, measured_c: float, dt_s: float) -> float:
        """The power for this period. The integral moves with the error but only as far as the output stays
        within [0, max] (clamping anti-windup): a large integral step near saturation is cut to the headroom,
        never refused whole, so a loop near full power still reaches its setpoint."""
        error = setpoint_c - measured_c
        if self.td > 0.0 and dt_s > 0.0 and self._last_measured_c is not None:
            raw = -self.kp * self.td * (measured_c - self._last_measured_c) / dt_s
            self.derivative_w += (raw - self.derivative_w) * dt_s / (self.td / DERIVATIVE_FILTER + dt_s)
        self._last_measured_c = measured_c
        proportional = self.kp * error + self.derivative_w
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
