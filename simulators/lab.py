"""The one simulated lab every emulator shares.

The slide's position changes what the bridge measures, the heater supply warms the
target, a heater in the thermal box warms the coil, temperatures follow first-order
dynamics, and the former holds moisture that heating drives out. Time comes from a
``SimulatedClock`` that the runner shares, so instruments interact as in the real set-up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ecds_lab.clock import SimulatedClock
from ecds_lab.data.sensor import TARGET_TAU_TEMPCO_PER_K
from ecds_lab.model import ecm
from ecds_lab.model.coupling import Coupling, image_method_coupling, table_coupling
from ecds_lab.simulators.config import LabConfig

#: Longest step of the thermal/moisture integration (s); inputs are constant within a step.
_MAX_STEP_S = 5.0

#: Which supply output drives which heater (station wiring of the simulated lab).
TARGET_HEATER_OUTPUT = 1
BOX_HEATER_OUTPUT = 2


@dataclass
class SupplyOutput:
    """One output of the heater supply: set values and the on/off state."""

    voltage_v: float = 0.0
    current_limit_a: float = 0.1
    on: bool = False


@dataclass
class Slide:
    """The slide's motor position (GRBL MPos, mm), with the move in progress if any."""

    motor_mm: float = 0.0
    move_from_mm: float = 0.0
    move_to_mm: float = 0.0
    move_start_s: float = 0.0
    move_duration_s: float = 0.0
    last_direction: int = 1
    carriage_error_mm: float = 0.0
    homed: bool = False

    def position(self, now: float) -> float:
        if self.move_duration_s <= 0 or now >= self.move_start_s + self.move_duration_s:
            return self.move_to_mm if self.move_duration_s > 0 else self.motor_mm
        fraction = (now - self.move_start_s) / self.move_duration_s
        return self.move_from_mm + fraction * (self.move_to_mm - self.move_from_mm)

    def moving(self, now: float) -> bool:
        return self.move_duration_s > 0 and now < self.move_start_s + self.move_duration_s


@dataclass
class Faults:
    """Failures a test can inject into the simulated instruments."""

    open_thermocouples: set[int] = field(default_factory=set)
    bridge_error_commands: set[str] = field(default_factory=set)
    silent_instruments: set[str] = field(default_factory=set)
    #: "instrument:COMMAND" -> how many of its replies are cut to half their length (-1: every one).
    short_replies: dict[str, int] = field(default_factory=dict)
    #: instrument -> lines it sends unasked, one before each of its next replies (then forgotten).
    unsolicited_lines: dict[str, list[str]] = field(default_factory=dict)


class SimulatedLab:
    """Physical state of the simulated set-up and the physics that turns it into readings."""

    def __init__(self, config: LabConfig | None = None, clock: SimulatedClock | None = None) -> None:
        self.config = config or LabConfig()
        self.clock = clock or SimulatedClock()
        self.rng = np.random.default_rng(self.config.seed)
        injected = self.config.faults
        self.faults = Faults(open_thermocouples=set(injected.open_thermocouples),
                             bridge_error_commands=set(injected.bridge_error_commands),
                             silent_instruments=set(injected.silent_instruments),
                             short_replies=dict(injected.short_replies),
                             unsolicited_lines={k: list(v) for k, v in injected.unsolicited_lines.items()})
        sensor = self.config.sensor
        self.coupling: Coupling = (
            table_coupling(sensor.coupling_table) if sensor.coupling_table else image_method_coupling(sensor.coil)
        )
        ambient = self.config.thermal.ambient_c
        self.t_box_c = ambient
        self.t_former_c = ambient
        self.t_winding_c = ambient
        self.t_target_c = ambient
        self.moisture = self.config.effects.parasitic_capacitance.initial_moisture
        self.slide = Slide()
        self.supply = {n: SupplyOutput() for n in (1, 2, 3, 4)}
        self._updated_at = self.clock.now()
        self._last_x_m, self._last_k2 = math.nan, 0.0

    # -- time ---------------------------------------------------------------------------------
    def update(self) -> None:
        """Integrate temperatures and moisture up to the clock's now (exact per constant-input step)."""
        now = self.clock.now()
        remaining = now - self._updated_at
        if remaining <= 0:
            return
        steps = max(1, math.ceil(remaining / _MAX_STEP_S))
        dt = remaining / steps
        th = self.config.thermal
        effects = self.config.effects
        p_target = self.heater_power_w(TARGET_HEATER_OUTPUT)
        p_box = self.heater_power_w(BOX_HEATER_OUTPUT)
        target_goal = th.ambient_c + p_target * th.target_k_per_w
        box_goal = th.ambient_c + p_box * th.box_k_per_w
        decay_target = math.exp(-dt / th.target_tau_s)
        decay_box = math.exp(-dt / th.box_tau_s)
        decay_former = math.exp(-dt / th.former_tau_s)
        lag = effects.thermal_lag
        decay_winding = math.exp(-dt / lag.tau_s) if lag.enabled else 0.0
        wet = effects.parasitic_capacitance
        for _ in range(steps):
            self.t_target_c = target_goal + (self.t_target_c - target_goal) * decay_target
            self.t_box_c = box_goal + (self.t_box_c - box_goal) * decay_box
            self.t_former_c = self.t_box_c + (self.t_former_c - self.t_box_c) * decay_former
            self.t_winding_c = self.t_former_c + (self.t_winding_c - self.t_former_c) * decay_winding
            if wet.enabled:
                dry = wet.drying_rate_at_100c_per_s * 2.0 ** ((self.t_former_c - 100.0) / wet.drying_doubling_k)
                total = dry + wet.absorption_rate_per_s
                equilibrium = wet.absorption_rate_per_s / total
                self.moisture = equilibrium + (self.moisture - equilibrium) * math.exp(-total * dt)
        self._updated_at = now

    # -- heater supply ------------------------------------------------------------------------
    def heater_load_ohm(self, output: int) -> float:
        th = self.config.thermal
        return {TARGET_HEATER_OUTPUT: th.target_heater_ohm, BOX_HEATER_OUTPUT: th.box_heater_ohm}.get(output, math.inf)

    def supply_readback(self, output: int) -> tuple[float, float]:
        """Voltage and current at an output: constant voltage, or constant current when limited."""
        out = self.supply[output]
        load = self.heater_load_ohm(output)
        if not out.on or math.isinf(load):
            return (out.voltage_v if out.on else 0.0), 0.0
        current = out.voltage_v / load
        if current > out.current_limit_a:
            return out.current_limit_a * load, out.current_limit_a
        return out.voltage_v, current

    def heater_power_w(self, output: int) -> float:
        if not self.supply[output].on:
            return 0.0
        volts, amps = self.supply_readback(output)
        return volts * amps

    def set_supply(self, output: int, **changes: float | bool) -> None:
        """Change an output's settings; temperatures are integrated up to now with the old ones first."""
        self.update()
        for name, value in changes.items():
            setattr(self.supply[output], name, value)

    # -- slide --------------------------------------------------------------------------------
    def start_move(self, target_mm: float, feed_mm_per_min: float) -> float:
        """Start a move of the slide motor; returns its duration in seconds."""
        now = self.clock.now()
        start = self.slide.position(now)
        distance = target_mm - start
        duration = abs(distance) / feed_mm_per_min * 60.0 if feed_mm_per_min > 0 else 0.0
        if distance:
            self.slide.last_direction = 1 if distance > 0 else -1
        self.slide.motor_mm = target_mm
        self.slide.move_from_mm, self.slide.move_to_mm = start, target_mm
        self.slide.move_start_s, self.slide.move_duration_s = now, duration
        sigma = self.config.noise.slide_repeatability_um * 1e-3
        self.slide.carriage_error_mm = float(self.rng.normal(0.0, sigma)) if sigma > 0 else 0.0
        return duration

    def halt_slide(self) -> None:
        """Feed hold / reset: the motor stops where it is now."""
        now = self.clock.now()
        here = self.slide.position(now)
        self.slide.motor_mm = self.slide.move_from_mm = self.slide.move_to_mm = here
        self.slide.move_duration_s = 0.0

    def distance_m(self) -> float:
        """True coil-target distance of the carriage (backlash and repeatability included), in m."""
        if not self.config.target_present:
            return math.inf
        carriage = self.slide.position(self.clock.now()) + self.slide.carriage_error_mm
        backlash = self.config.effects.slide_backlash
        if backlash.enabled:
            carriage -= self.slide.last_direction * backlash.backlash_um * 1e-3 / 2
        return (self.config.slide_origin_mm + carriage) * 1e-3

    # -- the coil as the bridge sees it -------------------------------------------------------
    def coil_impedance(self, frequency_hz: float) -> complex:
        """Impedance at the bridge terminals now: ECM Eq. (1)-(4) plus parallel C and loss."""
        self.update()
        cfg, sensor, effects = self.config, self.config.sensor, self.config.effects
        omega = 2 * math.pi * frequency_hz
        t_ref = sensor.reference_temperature_c
        d_coil = self.t_winding_c - t_ref
        l_coil = ecm.coil_inductance(sensor.inductance_h, cfg.alpha, cfg.beta_per_k2, d_coil)
        r_coil = sensor.resistance_ohm * (1 + sensor.resistance_tempco_per_k * d_coil)
        x = self.distance_m()
        k2, tau = 0.0, cfg.tau_t
        if math.isfinite(x):
            d_target = self.t_target_c - t_ref
            if effects.target_bending.enabled:
                x -= effects.target_bending.shift_um_per_k * 1e-6 * d_target
            k2 = self._coupling_squared(x)
            if effects.target_tau_temperature.enabled:
                tempco = effects.target_tau_temperature.tempco_per_k
                tempco = TARGET_TAU_TEMPCO_PER_K[sensor.target] if tempco is None else tempco
                tau *= 1 + tempco * d_target
            if effects.tau_displacement.enabled:
                tau *= 1 + effects.tau_displacement.slope_per_mm * (x * 1e3 - effects.tau_displacement.reference_mm)
        l_true = ecm.ecds_inductance(l_coil, k2, omega, tau)
        r_true = ecm.ecds_resistance(r_coil, l_coil, k2, omega, tau)
        wet = effects.parasitic_capacitance
        moisture = self.moisture if wet.enabled else 0.0
        capacitance = sensor.capacitance_f + wet.moist_extra_capacitance_f * moisture
        conductance = 1 / sensor.parallel_resistance_ohm + wet.moist_extra_conductance_s * moisture
        z = ecm.with_parallel_elements(complex(r_true, omega * l_true), omega, capacitance, 1 / conductance)
        if effects.bridge_drift.enabled:
            drift = effects.bridge_drift.ppm_per_hour * 1e-6 * self.clock.now() / 3600.0
            z = complex(z.real, z.imag * (1 + drift))
        return z

    def _coupling_squared(self, x_m: float) -> float:
        """k(x)^2, remembered for the last distance (the slide stands still for many readings)."""
        if x_m != self._last_x_m:
            self._last_x_m, self._last_k2 = x_m, float(self.coupling(x_m)) ** 2
        return self._last_k2

    def measured_impedance(self, frequency_hz: float, speed: str = "slow", voltage_v: float = 1.5,
                           averages: int = 1) -> complex:
        """What the bridge reads: the impedance now plus HM8118-like noise.

        Noise is relative to |Z|, set per speed for 1.5 V (``config.noise.bridge_relative``),
        growing as the test level falls and shrinking with the square root of the averages.
        """
        z = self.coil_impedance(frequency_hz)
        sigma = self.config.noise.bridge_relative[speed] * 1.5 / voltage_v / math.sqrt(max(1, averages))
        if sigma <= 0:
            return z
        real, imag = self.rng.standard_normal(2).tolist()
        return z + abs(z) * sigma * complex(real, imag)

    # -- thermocouples ------------------------------------------------------------------------
    def temperature_c(self, quantity: str) -> float:
        """True temperature of 'coil' (the former, where the thermocouple sits), 'target' or 'ambient'."""
        self.update()
        return {"coil": self.t_former_c, "target": self.t_target_c, "ambient": self.config.thermal.ambient_c}[quantity]

    def noisy(self, value: float, sigma: float) -> float:
        return value + float(self.rng.normal(0.0, sigma)) if sigma > 0 else value
