"""The heater supply driven towards each heater's goal: outputs, power limits, the PI loops, power read-back."""

from __future__ import annotations

import math
from collections.abc import Callable

from ecds_lab.clock import Clock
from ecds_lab.config.station import HeaterWiring, SafetyConfig
from ecds_lab.instruments.interfaces import HeaterSupply
from ecds_lab.runner.heater_control import HeaterGoal, PowerLoop, volts_for_power

HEATERS = ("target", "coil")


class Heaters:
    """What each heater should do and the supply outputs that do it, within the station's safety limits."""

    def __init__(self, supply: HeaterSupply, clock: Clock, wiring: HeaterWiring, safety: SafetyConfig, *,
                 read_back: bool, max_age_s: float) -> None:
        self.supply = supply
        self.clock = clock
        self.safety = safety
        self.read_back = read_back
        self.max_age_s = max_age_s
        self.outputs = {"target": wiring.target_output, "coil": wiring.coil_output}
        self.heater_ohm = {"target": wiring.target_heater_ohm, "coil": wiring.coil_heater_ohm}
        self.max_power_w = {h: min(safety.heater_max_voltage_v ** 2 / r, safety.heater_max_voltage_v
                                   * safety.heater_max_current_a) for h, r in self.heater_ohm.items()}
        self.goals = {h: HeaterGoal() for h in HEATERS}
        self.loops = {h: PowerLoop(self.max_power_w[h]) for h in HEATERS}
        self.powers_w = {h: math.nan for h in HEATERS}
        self._powers_at = -math.inf

    @property
    def heating(self) -> bool:
        """True while any heater holds a temperature or a power."""
        return any(goal.active for goal in self.goals.values())

    def set_goal(self, heater: str, goal: HeaterGoal, measured_c: Callable[[], float]) -> None:
        """Adopt a new goal with a fresh PI loop; off disables the output, otherwise it is set and enabled.

        ``measured_c`` is asked for the heater's temperature only when the goal is a setpoint.
        """
        self.goals[heater] = goal
        self.loops[heater] = PowerLoop(self.max_power_w[heater])
        output = self.outputs[heater]
        if not goal.active:
            self.supply.enable(output, False)
            return
        power = goal.power_w if goal.power_w is not None else self.loops[heater].update(
            goal.setpoint_c or 0.0, measured_c(), 0.0)
        self.apply_power(heater, power)
        self.supply.enable(output, True)

    def apply_power(self, heater: str, power_w: float) -> None:
        volts = volts_for_power(min(power_w, self.max_power_w[heater]), self.heater_ohm[heater],
                                self.safety.heater_max_voltage_v)
        self.supply.set_output(self.outputs[heater], volts, self.safety.heater_max_current_a)

    def control(self, dt_s: float, temperatures: dict[str, float]) -> None:
        """One control period for every heater that holds a temperature."""
        for heater, goal in self.goals.items():
            if goal.setpoint_c is not None:
                self.apply_power(heater, self.loops[heater].update(goal.setpoint_c, temperatures[heater], dt_s))

    def powers(self) -> dict[str, float]:
        """Delivered power per heater (W) from the supply's read-back (again once ``max_age_s`` old);
        NaN when the plan never heats."""
        if not self.read_back or self.clock.now() - self._powers_at < self.max_age_s:
            return self.powers_w
        for heater, output in self.outputs.items():
            volts, amps = self.supply.read_back(output)
            self.powers_w[heater] = volts * amps
        self._powers_at = self.clock.now()
        return self.powers_w
