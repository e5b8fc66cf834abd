"""The one simulated lab every emulator shares.

The slide's position changes what the bridge measures, the heater supply warms the
target, a heater in the thermal box warms the coil, temperatures follow first-order
dynamics, and the former holds moisture that heating drives out. Time comes from a
``SimulatedClock`` that the runner shares, so instruments interact as in the real set-up.

Temperatures (first-order nodes, exact per constant-input step): box air -> former surface
(the coil thermocouple) -> winding; target heaters -> plate bulk -> plate surface (the target
thermocouple). With ``physics: field`` the readings come from ``simulators/physics``
(docs/simulated_lab.md); with ``physics: ecm`` from the paper's equivalent circuit model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ecds_lab.clock import SimulatedClock
from ecds_lab.simulators.config import LabConfig, Thermal
from ecds_lab.simulators.physics import ecm
from ecds_lab.simulators.physics.bridge_model import BridgeModel
from ecds_lab.simulators.physics.field_sensor import FieldSensor
from ecds_lab.simulators.physics.field_solution import Winding
from ecds_lab.simulators.physics.former import FormerState
from ecds_lab.simulators.physics.plate import Plate
from ecds_lab.simulators.physics.slide_mechanics import carriage_error_m, draw_scatter_m
from ecds_lab.simulators.wider_world import WiderWorld

#: Longest step of the thermal/moisture integration (s); inputs are constant within a step.
_MAX_STEP_S = 5.0

#: Field-physics impedances remembered (per frequency and state); the memo is emptied when it grows beyond this.
_FIELD_MEMO_SIZE = 64
#: Thermal decay factors remembered (per step length, the least recently used forgotten first).
_DECAY_MEMO_SIZE = 64

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


@dataclass(frozen=True, slots=True)
class ThermalConstants:
    """The thermal model's constants as plain floats, taken from ``LabConfig.thermal`` when the lab is built: every
    reading steps the nodes with them, and a pydantic model's field costs several times a plain attribute."""

    ambient_c: float
    target_heater_ohm: float
    target_k_per_w: float
    target_tau_s: float
    box_heater_ohm: float
    box_k_per_w: float
    box_tau_s: float
    former_tau_s: float
    winding_tau_s: float | None

    @classmethod
    def of(cls, thermal: Thermal) -> ThermalConstants:
        return cls(**thermal.model_dump())


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
    #: "instrument:COMMAND" -> lines it sends unasked as soon as that command arrives, one per receipt.
    stale_lines: dict[str, list[str]] = field(default_factory=dict)


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
                             unsolicited_lines={k: list(v) for k, v in injected.unsolicited_lines.items()},
                             stale_lines={k: list(v) for k, v in injected.stale_lines.items()})
        cfg = self.config
        ambient = cfg.thermal.ambient_c
        self.field = cfg.physics == "field"
        #: The wider world's imperfections (``imperfections``), each None while off.
        self.wider = WiderWorld.of(cfg.imperfections, self._winding(), ambient, cfg.seed, self.clock.now())
        if self.field:
            plate = Plate(cfg.plate, cfg.plate_material)
            self.sensor = FieldSensor(cfg.coil, plate)
            self.plate = plate
            self.former = FormerState(cfg.former, cfg.former_material, ambient, self.wider.uptake)
            self.bridge_model = BridgeModel(cfg.bridge, cfg.seed)
        else:
            sensor = cfg.sensor
            coil = sensor.coil
            self.coupling: ecm.ImageCoupling | ecm.TableCoupling = (
                ecm.TableCoupling(sensor.coupling_table) if sensor.coupling_table else ecm.ImageCoupling(
                    Winding(coil.inner_radius_m, coil.outer_radius_m, coil.height_m, coil.turns),
                    coil.radial_filaments, coil.axial_filaments))
        self.t_box_c = ambient
        self.t_former_c = ambient
        self.t_winding_c = ambient
        self.t_target_c = ambient
        self.t_plate_surface_c = ambient
        self.moisture = cfg.effects.parasitic_capacitance.initial_moisture
        self.slide = Slide()
        self.supply = {n: SupplyOutput() for n in (1, 2, 3, 4)}
        self._updated_at = self.clock.now()
        #: The thermal constants the nodes are stepped with (fixed once the lab is built).
        self.thermal = ThermalConstants.of(cfg.thermal)
        # Read on every reading, held directly (the same object: changes to its fields still count).
        self._drift = cfg.effects.bridge_drift
        self._outside_the_bridge = self.wider.at_the_bridge
        #: State beyond the memo key's own that the field impedance depends on (None: nothing beyond it).
        self._extra_state = self._wider_state if self.wider.beyond_the_memo_key else None
        self._carriage_key: tuple[float, int, float] = (math.nan, 0, math.nan)
        self._carriage_error = 0.0
        self._field_memo: dict[tuple[float, ...], complex] = {}
        #: The nodes' decay factors over a step: fixed per step length (the thermal constants are fixed once the
        #: lab is built), and a run's readings come at a few intervals.
        self._node_decays = lru_cache(maxsize=_DECAY_MEMO_SIZE)(self._node_decays_over)

    def _winding(self) -> Winding:
        """The winding of the physics in use (field: the ``coil`` block; ECM: the sensor's coil)."""
        if self.field:
            return self.config.coil.winding()
        coil = self.config.sensor.coil
        return Winding(coil.inner_radius_m, coil.outer_radius_m, coil.height_m, coil.turns)

    def _wider_state(self) -> tuple[float, ...]:
        """What the wider world's imperfections add to the state a field impedance depends on."""
        play = self.wider.play
        return (self.distance_m(without_target=True), play.temperature_c if play is not None else 0.0)

    def _expansion_temperature_c(self) -> float:
        """The temperature that sets the winding's thermal strain: the winding's own, or the play's behind it."""
        play = self.wider.play
        return play.temperature_c if play is not None else self.t_winding_c

    # -- time ---------------------------------------------------------------------------------
    def update(self) -> None:
        """Integrate temperatures and moisture up to the clock's now (exact per constant-input step)."""
        now = self.clock.now()
        remaining = now - self._updated_at
        if remaining <= 0:
            return
        steps = 1 if remaining <= _MAX_STEP_S else math.ceil(remaining / _MAX_STEP_S)
        dt = remaining / steps
        th = self.thermal
        ambient = th.ambient_c
        p_target = self.heater_power_w(TARGET_HEATER_OUTPUT)
        p_box = self.heater_power_w(BOX_HEATER_OUTPUT)
        target_goal = ambient + p_target * th.target_k_per_w
        box_goal = ambient + p_box * th.box_k_per_w
        decay_target, decay_box, decay_former, decay_winding, decay_surface = self._node_decays(dt)
        wet = None  # the ECM physics' moisture, when that effect is on
        if not self.field and self.config.effects.parasitic_capacitance.enabled:
            wet = self.config.effects.parasitic_capacitance
            uptake = self.wider.uptake
        # The nodes as locals while stepping (stored back below): the same arithmetic, less attribute traffic.
        t_target, t_surface, t_box = self.t_target_c, self.t_plate_surface_c, self.t_box_c
        t_former, t_winding = self.t_former_c, self.t_winding_c
        play = self.wider.play
        for _ in range(steps):
            t_target = target_goal + (t_target - target_goal) * decay_target
            t_surface = t_target + (t_surface - t_target) * decay_surface
            t_box = box_goal + (t_box - box_goal) * decay_box
            t_former = t_box + (t_former - t_box) * decay_former
            t_winding = t_former + (t_winding - t_former) * decay_winding
            if play is not None:
                play.follow(t_winding)
            if self.field:
                self.former.step(t_former, dt)
            elif wet is not None:
                dry = wet.drying_rate_at_100c_per_s * 2.0 ** ((t_former - 100.0) / wet.drying_doubling_k)
                absorb = wet.absorption_rate_per_s if uptake is None else 1.0 / uptake.taus_s(t_former)[0]
                total = dry + absorb
                equilibrium = absorb / total
                self.moisture = equilibrium + (self.moisture - equilibrium) * math.exp(-total * dt)
        self.t_target_c, self.t_plate_surface_c, self.t_box_c = t_target, t_surface, t_box
        self.t_former_c, self.t_winding_c = t_former, t_winding
        self._updated_at = now

    def _node_decays_over(self, dt: float) -> tuple[float, float, float, float, float]:
        """Factors by which each node's distance to its goal shrinks over dt: target, box, former, winding, surface."""
        th = self.thermal
        decay_target = math.exp(-dt / th.target_tau_s)
        decay_box = math.exp(-dt / th.box_tau_s)
        decay_former = math.exp(-dt / th.former_tau_s)
        if self.field:
            winding_tau_s = th.winding_tau_s
            decay_winding = math.exp(-dt / winding_tau_s) if winding_tau_s else 0.0
            decay_surface = math.exp(-dt / self.plate.surface_lag_s)
        else:
            lag = self.config.effects.thermal_lag
            decay_winding = math.exp(-dt / lag.tau_s) if lag.enabled else 0.0
            decay_surface = 0.0
        return decay_target, decay_box, decay_former, decay_winding, decay_surface

    # -- heater supply ------------------------------------------------------------------------
    def heater_load_ohm(self, output: int) -> float:
        if output == TARGET_HEATER_OUTPUT:
            return self.thermal.target_heater_ohm
        return self.thermal.box_heater_ohm if output == BOX_HEATER_OUTPUT else math.inf

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

    def heater_currents_a(self) -> tuple[float, float]:
        """The currents flowing through the target and box heaters now (A)."""
        return self.supply_readback(TARGET_HEATER_OUTPUT)[1], self.supply_readback(BOX_HEATER_OUTPUT)[1]

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
        if self.field:
            self.slide.carriage_error_mm = draw_scatter_m(self.config.slide, self.rng) * 1e3
        else:
            sigma = self.config.noise.slide_repeatability_um * 1e-3
            self.slide.carriage_error_mm = float(self.rng.normal(0.0, sigma)) if sigma > 0 else 0.0
        return duration

    def halt_slide(self) -> None:
        """Feed hold / reset: the motor stops where it is now."""
        now = self.clock.now()
        here = self.slide.position(now)
        self.slide.motor_mm = self.slide.move_from_mm = self.slide.move_to_mm = here
        self.slide.move_duration_s = 0.0

    def distance_m(self, without_target: bool = False) -> float:
        """True coil-target distance of the carriage (backlash and repeatability included), in m; inf when the
        target is removed, unless ``without_target`` asks where the carriage is all the same."""
        if not (self.config.target_present or without_target):
            return math.inf
        motor = self.slide.position(self.clock.now())
        if self.field:
            return (self.config.slide_origin_mm + motor) * 1e-3 + self._carriage_error_m(motor)
        carriage = motor + self.slide.carriage_error_mm
        backlash = self.config.effects.slide_backlash
        if backlash.enabled:
            carriage -= self.slide.last_direction * backlash.backlash_um * 1e-3 / 2
        return (self.config.slide_origin_mm + carriage) * 1e-3

    def _carriage_error_m(self, motor_mm: float) -> float:
        """The carriage's error at this motor position (field physics), remembered for the last position, direction
        and scatter: between moves every reading asks the same (the slide mechanics settings are fixed per lab)."""
        slide = self.slide
        key = (motor_mm, slide.last_direction, slide.carriage_error_mm)
        if key != self._carriage_key:
            self._carriage_error = carriage_error_m(self.config.slide, motor_mm, slide.last_direction,
                                                    slide.carriage_error_mm * 1e-3)
            self._carriage_key = key
        return self._carriage_error

    # -- the coil as the bridge sees it -------------------------------------------------------
    def coil_impedance(self, frequency_hz: float) -> complex:
        """Impedance at the bridge terminals now (the physics the station's config chose)."""
        self.update()
        omega = 2 * math.pi * frequency_hz
        z = self._field_impedance(omega) if self.field else self._ecm_impedance(omega)
        drift = self._drift
        if drift.enabled:
            gain = 1 + drift.ppm_per_hour * 1e-6 * self.clock.now() / 3600.0
            z = complex(z.real, z.imag * gain)
        return z

    def _field_impedance(self, omega: float) -> complex:
        """Dodd & Deeds coil over the plate, the former's strain, C and loss, and the wider world's imperfections
        that change the coil itself (docs/simulated_lab.md).

        Memoised on the state it depends on (the settings are fixed once the lab is built), so a remembered value
        is exactly what computing it again would give; a sweep reads one state many times in a row.
        """
        x_m = self.distance_m()
        former = self.former
        key: tuple[float, ...] = (omega, x_m, self.t_winding_c, self.t_plate_surface_c, former.groove, former.bulk)
        if self._extra_state is not None:
            key += self._extra_state()
        z = self._field_memo.get(key)
        if z is None:
            z = self._field_impedance_at(omega, x_m)
            if len(self._field_memo) >= _FIELD_MEMO_SIZE:
                self._field_memo.clear()
            self._field_memo[key] = z
        return z

    def _field_impedance_at(self, omega: float, x_m: float) -> complex:
        ambient = self.thermal.ambient_c
        t_plate = self.plate.field_temperature_c(self.t_plate_surface_c, ambient)
        wider = self.wider
        strain = self.former.strain(self._expansion_temperature_c())
        gaps = wider.tilt.gaps_m(x_m, self.t_plate_surface_c) if wider.tilt is not None else None
        if gaps is None:
            branch = self.sensor.series_branch(omega, x_m, self.t_winding_c, t_plate, ambient, strain)
        else:  # a tilted plate: the coupling averaged over the coil's face
            branch = sum(self.sensor.series_branch(omega, gap, self.t_winding_c, t_plate, ambient, strain)
                         for gap in gaps) / len(gaps)
        if wider.metal is not None:
            branch += 1j * omega * wider.metal.inductance_h(omega, self.distance_m(without_target=True))
        capacitance, conductance = self.former.parallel_elements(omega / (2 * math.pi))
        return ecm.with_parallel(branch, omega, capacitance, conductance)

    def _ecm_impedance(self, omega: float) -> complex:
        """ECM Eq. (1)-(4) plus parallel C and loss, with the ECM effects switched on in ``effects``."""
        cfg, sensor, effects = self.config, self.config.sensor, self.config.effects
        t_ref = sensor.reference_temperature_c
        d_coil = self.t_winding_c - t_ref
        wider = self.wider
        d_expansion = d_coil if wider.play is None else wider.play.temperature_c - t_ref
        l_coil = sensor.inductance_h * (1 + cfg.alpha * d_expansion + cfg.beta_per_k2 * d_coil**2)
        r_coil = sensor.resistance_ohm * (1 + sensor.resistance_tempco_per_k * d_coil)
        x = self.distance_m()
        k2, tau = 0.0, cfg.tau_t
        if math.isfinite(x):
            d_target = self.t_target_c - t_ref
            if effects.target_bending.enabled:
                x -= effects.target_bending.shift_um_per_k * 1e-6 * d_target
            gaps = wider.tilt.gaps_m(x, self.t_target_c) if wider.tilt is not None else None
            k2 = self.coupling.k2(x) if gaps is None else sum(self.coupling.k2(gap) for gap in gaps) / len(gaps)
            if effects.target_tau_temperature.enabled:
                tempco = effects.target_tau_temperature.tempco_per_k
                tempco = ecm.tau_tempco_per_k(sensor.target) if tempco is None else tempco
                tau *= 1 + tempco * d_target
            if effects.tau_displacement.enabled:
                tau *= 1 + effects.tau_displacement.slope_per_mm * (x * 1e3 - effects.tau_displacement.reference_mm)
        wet = effects.parasitic_capacitance
        moisture = self.moisture if wet.enabled else 0.0
        capacitance = sensor.capacitance_f + wet.moist_extra_capacitance_f * moisture
        conductance = 1 / sensor.parallel_resistance_ohm + wet.moist_extra_conductance_s * moisture
        branch = ecm.series_branch(l_coil, r_coil, k2, omega, tau)
        if wider.metal is not None:
            branch += 1j * omega * wider.metal.inductance_h(omega, self.distance_m(without_target=True))
        return ecm.with_parallel(branch, omega, capacitance, conductance)

    def measured_impedance(self, frequency_hz: float, speed: str = "slow", voltage_v: float = 1.5,
                           averages: int = 1) -> complex:
        """What the bridge reads: the impedance now plus the bridge's noise (and, field physics, its
        basic accuracy and rare glitches: ``simulators/physics/bridge_model``).

        ECM physics: noise relative to |Z| per speed at 1.5 V (``config.noise.bridge_relative``),
        growing as the test level falls and shrinking with the square root of the averages.
        Either physics: the bridge's gain drift (``imperfections.bridge_gain_drift``) and the heater current's
        pickup (``imperfections.bridge_heater_pickup``) when on.
        """
        z = self.coil_impedance(frequency_hz)
        if self._outside_the_bridge:
            return self._read_with_outside_effects(z, frequency_hz, speed, voltage_v, averages)
        if self.field:
            return self.bridge_model.read(z, frequency_hz, speed, voltage_v, averages, self.rng)
        sigma = self.config.noise.bridge_relative[speed] * 1.5 / voltage_v / math.sqrt(max(1, averages))
        if sigma <= 0:
            return z
        real, imag = self.rng.standard_normal(2).tolist()
        return z + abs(z) * sigma * complex(real, imag)

    def _read_with_outside_effects(self, z: complex, frequency_hz: float, speed: str, voltage_v: float,
                                   averages: int) -> complex:
        """``measured_impedance`` with the bridge's gain drift and the heater current's pickup (either or both on):
        the impedance scaled by the gain, the pickup's noise in quadrature with the bridge's own (same draws)."""
        wider = self.wider
        if wider.gain_drift is not None:
            z = z * wider.gain_drift.gain(self.clock.now())
        extra = 0.0
        if wider.pickup is not None:
            extra = wider.pickup.relative(self.heater_currents_a(), speed, voltage_v, averages)
        if self.field:
            return self.bridge_model.read(z, frequency_hz, speed, voltage_v, averages, self.rng, extra)
        sigma = math.hypot(self.config.noise.bridge_relative[speed] * 1.5 / voltage_v / math.sqrt(max(1, averages)),
                           extra)
        if sigma <= 0:
            return z
        real, imag = self.rng.standard_normal(2).tolist()
        return z + abs(z) * sigma * complex(real, imag)

    # -- thermocouples ------------------------------------------------------------------------
    def temperature_c(self, quantity: str) -> float:
        """True temperature where a thermocouple sits: 'coil' (the former's surface), 'target' (the plate's
        surface; with ECM physics the one plate node) or 'ambient'."""
        self.update()
        if quantity == "coil":
            return self.t_former_c
        if quantity == "target":
            return self.t_plate_surface_c if self.field else self.t_target_c
        if quantity == "ambient":
            return self.thermal.ambient_c
        raise KeyError(quantity)

    def noisy(self, value: float, sigma: float) -> float:
        """``value`` plus normal noise; sigma times a standard normal is the draw ``rng.normal(0, sigma)`` makes
        (numpy computes 0 + sigma z from the same z), without its per-call argument handling."""
        return value + sigma * self.rng.standard_normal() if sigma > 0 else value
