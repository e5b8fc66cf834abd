"""The heater supply driven towards each heater's goal: outputs, power limits, the PI loops, power read-back."""

from __future__ import annotations

import math
from collections.abc import Callable

from ecds_lab.clock import Clock
from ecds_lab.config.station import HeaterWiring, LoopGains, RegulationConfig, SafetyConfig
from ecds_lab.instruments.interfaces import HeaterSupply
from ecds_lab.runner.heater_control import HeaterGoal, PowerLoop, volts_for_power

HEATERS = ("target", "coil")
#: Control period until a heater wait sets the experiment's (s).
DEFAULT_PERIOD_S = 10.0


class Heaters:
    """What each heater should do and the supply outputs that do it, within the station's safety limits."""

    def __init__(self, supply: HeaterSupply, clock: Clock, wiring: HeaterWiring, safety: SafetyConfig, *,
                 read_back: bool, max_age_s: float, regulation: RegulationConfig | None = None) -> None:
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
        regulation = regulation or RegulationConfig()
        #: Each loop's gains: the station's, until an identification proposes others.
        self.gains: dict[str, LoopGains] = {"target": regulation.target, "coil": regulation.coil}
        self.loops = {h: PowerLoop(self.max_power_w[h], self.gains[h]) for h in HEATERS}
        #: How often the loops run (s): the period of the latest heater wait.
        self.period_s = DEFAULT_PERIOD_S
        #: Identified steady rise per watt (K/W) of each heater's plant, for the holding power of a new setpoint.
        self.plant_gain_k_per_w: dict[str, float] = {}
        self._controlled_at = {h: -math.inf for h in HEATERS}
        self.powers_w = {h: math.nan for h in HEATERS}
        self._powers_at = -math.inf

    @property
    def heating(self) -> bool:
        """True while any heater holds a temperature or a power."""
        return any(goal.active for goal in self.goals.values())

    def set_goal(self, heater: str, goal: HeaterGoal, temperatures: Callable[[], dict[str, float]]) -> None:
        """Adopt a new goal with a fresh PI loop; off disables the output, otherwise it is set and enabled.

        ``temperatures`` (the thermocouples by name) is asked only when the goal is a setpoint. An identified
        heater's loop starts from the power expected to hold the setpoint (:meth:`holding_power_w`).
        """
        self.goals[heater] = goal
        self.loops[heater] = PowerLoop(self.max_power_w[heater], self.gains[heater])
        self._controlled_at[heater] = self.clock.now()
        output = self.outputs[heater]
        if not goal.active:
            self.supply.enable(output, False)
            return
        if goal.power_w is not None:
            power = goal.power_w
        else:
            assert goal.setpoint_c is not None
            measured = temperatures()
            loop = self.loops[heater]
            loop.integral_w = self.holding_power_w(heater, goal.setpoint_c, measured.get("ambient", math.nan))
            power = loop.update(goal.setpoint_c, measured[heater], 0.0)
        self.apply_power(heater, power)
        self.supply.enable(output, True)

    def holding_power_w(self, heater: str, setpoint_c: float, ambient_c: float) -> float:
        """The power expected to hold ``setpoint_c``, from the identified plant's rise per watt over the ambient
        thermocouple (a feed-forward the loop starts from); 0 when the plant was not identified, so the loop
        integrates up to it as with the station's fixed gains. Within [0, max]."""
        gain = self.plant_gain_k_per_w.get(heater)
        if gain is None or not math.isfinite(ambient_c) or setpoint_c <= ambient_c:
            return 0.0
        return min(max((setpoint_c - ambient_c) / gain, 0.0), self.max_power_w[heater])

    def apply_power(self, heater: str, power_w: float) -> None:
        volts = volts_for_power(min(power_w, self.max_power_w[heater]), self.heater_ohm[heater],
                                self.safety.heater_max_voltage_v)
        self.supply.set_output(self.outputs[heater], volts, self.safety.heater_max_current_a)

    @property
    def regulating(self) -> bool:
        """True while any heater holds a temperature (its loop must run, whatever the runner is doing)."""
        return any(goal.setpoint_c is not None for goal in self.goals.values())

    def control_due(self) -> bool:
        """True when a heater that holds a temperature was last controlled a period ago or more."""
        now = self.clock.now()
        return any(goal.setpoint_c is not None and now - self._controlled_at[heater] >= self.period_s
                   for heater, goal in self.goals.items())

    def seconds_to_next_control(self) -> float:
        """Time until the next control is due (inf when no heater holds a temperature)."""
        now = self.clock.now()
        due = [self._controlled_at[h] + self.period_s - now for h, g in self.goals.items() if g.setpoint_c is not None]
        return max(min(due), 0.0) if due else math.inf

    def control(self, temperatures: dict[str, float]) -> None:
        """One control update for every heater that holds a temperature, integrating over the time since its last."""
        now = self.clock.now()
        for heater, goal in self.goals.items():
            if goal.setpoint_c is not None:
                dt_s = max(now - self._controlled_at[heater], 0.0)
                self._controlled_at[heater] = now
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
