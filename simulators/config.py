"""Settings of the simulated lab: which physics, the set-up's parts, thermal constants, noise.

``physics: field`` (the faithful lab) computes readings from the lab's own physics
(``simulators/physics``: Dodd & Deeds field solution, former expansion and moisture, plate
materials and bending, carriage mechanics, bridge imperfections), each a named, sizeable,
switchable block here. ``physics: ecm`` computes them with the paper's equivalent circuit model
from ``sensor`` and switches on the model library's named effects from ``effects`` one by one, so tests can
have the analysis model exact or with one hidden effect. The default is ``ecm``; the shipped
simulated stations choose ``field``. ``imperfections`` holds the wider world's physics (bridge gain drift and
heater pickup, a metal object beside the slide, a tilting target, a hysteresis of the former's expansion,
re-absorption of humidity), each off by default and acting with either physics.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ecds_lab.data.sensor import SensorConfig
from ecds_lab.simulators.physics.bridge_gain import BridgeGainDrift
from ecds_lab.simulators.physics.bridge_model import BridgeModelSettings
from ecds_lab.simulators.physics.coil import CoilSettings
from ecds_lab.simulators.physics.expansion_hysteresis import ExpansionHysteresis
from ecds_lab.simulators.physics.former import FormerSettings
from ecds_lab.simulators.physics.heater_pickup import BridgeHeaterPickup
from ecds_lab.simulators.physics.humidity_uptake import Reabsorption
from ecds_lab.simulators.physics.metal_object import MetalObject
from ecds_lab.simulators.physics.plate import PlateSettings
from ecds_lab.simulators.physics.slide_mechanics import SlideMechanicsSettings
from ecds_lab.simulators.physics.target_tilt import TargetTilt


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class TargetTauTemperature(_Strict):
    """tau_T follows the target's conductivity: tau = tau0 (1 + tempco (T_target - T_ref))."""

    enabled: bool = False
    tempco_per_k: float | None = Field(None, description="default: the material's (copper -0.0039/K, aluminium "
                                                         "-0.0043/K, brass -0.0015/K, steel -0.0030/K)")


class TauDisplacement(_Strict):
    """tau_T depends on distance: tau = tau0 (1 + slope (x - x_ref))."""

    enabled: bool = False
    slope_per_mm: float = -0.004
    reference_mm: float = 60.0


class TargetBending(_Strict):
    """The hot plate bends toward the coil: effective x = x - shift (T_target - T_ref)."""

    enabled: bool = False
    shift_um_per_k: float = 2.0


class ParasiticCapacitance(_Strict):
    """The former's moisture m (0 dry .. 1 saturated) adds capacitance and loss; heat drives it out.

    dm/dt = -m r_dry(T) + (1 - m) r_absorb, with r_dry(T) = rate_at_100c * 2^((T - 100 C)/doubling_k).
    """

    enabled: bool = False
    initial_moisture: float = Field(1.0, ge=0, le=1)
    moist_extra_capacitance_f: float = Field(15e-12, ge=0, description="Table 2: 62.5 pF moist vs 47.5 pF dry")
    moist_extra_conductance_s: float = Field(9.85e-6, ge=0, description="Table 2: 92 kOhm moist vs 984 kOhm dry")
    drying_rate_at_100c_per_s: float = Field(1.0 / 600.0, gt=0)
    drying_doubling_k: float = Field(12.0, gt=0)
    absorption_rate_per_s: float = Field(1.0 / (3 * 24 * 3600.0), ge=0)


class ThermalLag(_Strict):
    """The winding lags the former's thermocouple with a first-order time constant."""

    enabled: bool = False
    tau_s: float = Field(300.0, gt=0)


class SlideBacklash(_Strict):
    """The carriage trails the motor by half the backlash in the direction of the last move."""

    enabled: bool = False
    backlash_um: float = Field(40.0, ge=0)


class BridgeDrift(_Strict):
    """Not in the model library: the bridge's L reading drifts linearly in time (a test of the diagnosis)."""

    enabled: bool = False
    ppm_per_hour: float = 200.0


class Effects(_Strict):
    """Switches and sizes of every effect the ECM physics can add to the baseline (``physics: ecm``;
    only ``bridge_drift`` also applies to the field physics, whose parts are the coil/former/plate/slide/bridge
    blocks)."""

    target_tau_temperature: TargetTauTemperature = TargetTauTemperature()
    tau_displacement: TauDisplacement = TauDisplacement()
    target_bending: TargetBending = TargetBending()
    parasitic_capacitance: ParasiticCapacitance = ParasiticCapacitance()
    thermal_lag: ThermalLag = ThermalLag()
    slide_backlash: SlideBacklash = SlideBacklash()
    bridge_drift: BridgeDrift = BridgeDrift()

    def enabled(self) -> list[str]:
        return [name for name in type(self).model_fields if getattr(self, name).enabled]


class Thermal(_Strict):
    """First-order thermal model of the set-up (time constants in s, resistances in K/W)."""

    ambient_c: float = 22.0
    target_heater_ohm: float = Field(8.0, gt=0)
    target_k_per_w: float = Field(1.0, gt=0, description="steady target rise per heater watt")
    target_tau_s: float = Field(600.0, gt=0)
    box_heater_ohm: float = Field(8.0, gt=0)
    box_k_per_w: float = Field(1.2, gt=0, description="steady thermal-box rise per heater watt")
    box_tau_s: float = Field(120.0, gt=0)
    former_tau_s: float = Field(900.0, gt=0)
    winding_tau_s: float | None = Field(300.0, gt=0, description="physics field: the winding lags the former's "
                                                                  "thermocouple (None: no lag)")


class Noise(_Strict):
    """Measurement noise: bridge (relative, per speed, at 1.5 V and no averaging), thermocouples, slide.

    With ``physics: field`` only ``thermocouple_k`` applies; the ``bridge`` and ``slide`` blocks size the rest.
    """

    bridge_relative: dict[str, float] = {"fast": 200e-6, "medium": 60e-6, "slow": 20e-6}
    thermocouple_k: float = Field(0.02, ge=0)
    slide_repeatability_um: float = Field(0.0, ge=0)


class InjectedFaults(_Strict):
    """Failures the simulated instruments show from the start (for recorded error sessions and tests).

    Applied by ``SimulatedLab.__init__`` to ``lab.faults``, which tests may also change while running.
    """

    bridge_error_commands: list[str] = Field(
        [], description="the bridge answers ERROR to these: a mnemonic (FREQ: every frequency) "
                        "or a whole command in upper case (FREQ 15000: only that one)")
    open_thermocouples: list[int] = Field([], description="scanner channels whose thermocouple reads open")
    silent_instruments: list[Literal["hm8118", "grbl", "daq970a", "34970a", "hmp4040"]] = Field(
        [], description="emulators that never answer")
    short_replies: dict[str, int] = Field(
        {}, description="'instrument:COMMAND' (e.g. 'hm8118:XALL?') -> how many replies to it are cut to half "
                        "their length (-1: every one)")
    unsolicited_lines: dict[str, list[str]] = Field(
        {}, description="instrument -> lines it sends unasked, one before each of its next replies")
    stale_lines: dict[str, list[str]] = Field(
        {}, description="'instrument:COMMAND' (e.g. 'hm8118:*TRG') -> lines it sends unasked the moment it "
                        "receives that command, one per receipt: they wait on the link when the host's next "
                        "query goes out (a line left from an earlier exchange)")


class Imperfections(_Strict):
    """Imperfections of the wider world (docs/simulated_lab.md), each off by default and acting with either
    physics: physical effects of the set-up beyond the parts above, each its own named, sized block."""

    bridge_gain_drift: BridgeGainDrift = BridgeGainDrift()
    bridge_heater_pickup: BridgeHeaterPickup = BridgeHeaterPickup()
    metal_object: MetalObject = MetalObject()
    target_tilt: TargetTilt = TargetTilt()
    expansion_hysteresis: ExpansionHysteresis = ExpansionHysteresis()
    reabsorption: Reabsorption = Reabsorption()

    def enabled(self) -> list[str]:
        return [name for name in type(self).model_fields if getattr(self, name).enabled]


class LabConfig(_Strict):
    """One simulated lab: the physics, the sensor on the slide, the target, the climate, noise and effects."""

    physics: Literal["ecm", "field"] = Field("ecm", description="field: the faithful lab; ecm: the paper's model")
    sensor: SensorConfig = SensorConfig()
    coil: CoilSettings = Field(CoilSettings(), description="physics field: the winding")
    former: FormerSettings = Field(FormerSettings(), description="physics field: expansion and moisture")
    plate: PlateSettings = Field(PlateSettings(), description="physics field: the target plate")
    slide: SlideMechanicsSettings = Field(SlideMechanicsSettings(), description="physics field: carriage errors")
    bridge: BridgeModelSettings = Field(BridgeModelSettings(), description="physics field: bridge imperfections")
    alpha_per_k: float | None = Field(None, description="Eq. (4) alpha; default 2x the former's expansion")
    beta_per_k2: float = 2e-8
    tau_t_s: float | None = Field(None, gt=0, description="default: the target material's tau_T")
    slide_origin_mm: float = Field(160.0, description="coil-target distance when the slide is at MPos 0")
    target_present: bool = True
    thermocouple_channels: dict[int, Literal["coil", "target", "ambient"]] = Field(
        {101: "coil", 102: "target", 103: "ambient"},
        description="scanner channel -> the lab temperature its thermocouple measures; other channels are open",
    )
    thermal: Thermal = Thermal()
    noise: Noise = Noise()
    effects: Effects = Effects()
    imperfections: Imperfections = Field(Imperfections(), description="the wider world: off unless enabled")
    faults: InjectedFaults = InjectedFaults()
    seed: int | None = 1

    @model_validator(mode="after")
    def _one_description(self) -> LabConfig:
        """The field blocks' materials must agree with the sensor description; ECM effects are ECM-only."""
        if self.former.material is not None and self.former.material != self.sensor.former:
            raise ValueError(f"former.material {self.former.material!r} differs from sensor.former "
                             f"{self.sensor.former!r}; give one of them")
        if self.plate.material is not None and self.plate.material != self.sensor.target:
            raise ValueError(f"plate.material {self.plate.material!r} differs from sensor.target "
                             f"{self.sensor.target!r}; give one of them")
        metal = self.imperfections.metal_object
        outer_mm = (self.coil.outer_radius_m if self.physics == "field" else self.sensor.coil.outer_radius_m) * 1e3
        if metal.enabled and metal.radial_mm - metal.radius_mm <= outer_mm:
            raise ValueError(f"imperfections.metal_object.radial_mm: an object of radius {metal.radius_mm:g} mm at "
                             f"{metal.radial_mm:g} mm from the coil's axis would touch the winding (outer radius "
                             f"{outer_mm:g} mm); place it further out")
        if self.physics == "field":
            ecm_only = [name for name in self.effects.enabled() if name != "bridge_drift"]
            if ecm_only:
                raise ValueError(f"effects {ecm_only} belong to physics: ecm; with physics: field the lab's "
                                 "coil, former, plate, slide and bridge blocks size the physics")
        return self

    @property
    def former_material(self) -> str:
        return self.former.material or self.sensor.former

    @property
    def plate_material(self) -> str:
        return self.plate.material or self.sensor.target

    @property
    def alpha(self) -> float:
        return self.alpha_per_k if self.alpha_per_k is not None else 2 * self.sensor.former_expansion_per_k

    @property
    def tau_t(self) -> float:
        return self.tau_t_s if self.tau_t_s is not None else self.sensor.target_tau_s
