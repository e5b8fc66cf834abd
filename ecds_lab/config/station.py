"""Station configuration: which instruments, on which ports, with which driver, or the simulated lab.

A station YAML names four roles (bridge, slide, scanner, heater). Each role has a
driver and a transport (a pyserial URL or a VISA resource). With ``simulated:``
the transports default to the in-process simulators of one shared simulated lab.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from ecds_lab.data.sensor import SensorConfig, load_sensor
from ecds_lab.errors import ConfigError
from ecds_lab.instruments.kinds import KINDS, ROLE_NAMES, drivers_for_role
from ecds_lab.simulators.config import LabConfig


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class SerialLink(_Strict):
    """A pyserial port: a device (/dev/ttyUSB0, COM3) or URL (socket://host:port, ecdssim://lab/instr)."""

    kind: Literal["serial"] = "serial"
    url: str
    baudrate: int | None = None
    timeout_s: float | None = Field(None, gt=0)


class VisaLink(_Strict):
    """A VISA resource (TCPIP0::host::5025::SOCKET, USB0::..., ASRL/dev/ttyS0::INSTR)."""

    kind: Literal["visa"] = "visa"
    resource: str
    backend: str = "@py"
    timeout_s: float | None = Field(None, gt=0)


class InstrumentConfig(_Strict):
    """One instrument of the station: driver, link, and driver options."""

    driver: str = Field(description="an instrument kind of ecds_lab.instruments.kinds (hm8118, grbl, ...)")
    link: SerialLink | VisaLink | None = Field(None, discriminator="kind")
    options: dict[str, Any] = {}
    min_interval_s: float | None = Field(None, ge=0, description="pause between commands; default per driver")
    repeatability_um: float | None = Field(None, description="slide only: the positioning repeatability (1 sigma, "
                                           "um) from the slide's datasheet; counted in the noise models are "
                                           "judged against (recorded in every run file)")

    @field_validator("repeatability_um")
    @classmethod
    def _repeatability_not_negative(cls, value: float | None) -> float | None:
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise ValueError(f"repeatability_um must be a finite number >= 0 (1 sigma in um, from the slide's "
                             f"datasheet), got {value}")
        return value

    @field_validator("driver")
    @classmethod
    def _known_driver(cls, driver: str) -> str:
        if driver not in KINDS:
            known = ", ".join(f"{name!r} ({'/'.join(row.roles)})" for name, row in KINDS.items())
            raise ValueError(f"unknown driver {driver!r}; allowed: {known}")
        return driver

    @model_validator(mode="after")
    def _link_fits_driver(self) -> InstrumentConfig:
        links = KINDS[self.driver].links
        if self.link is not None and self.link.kind not in links:
            raise ValueError(f"driver {self.driver!r} has no {self.link.kind} link; allowed: {', '.join(links)}")
        return self


class SafetyConfig(_Strict):
    """Interlocks that switch the heater off."""

    max_temperature_c: dict[str, float] = {"coil": 140.0, "target": 140.0, "ambient": 45.0}
    heater_max_voltage_v: float = Field(30.0, gt=0)
    heater_max_current_a: float = Field(4.0, gt=0)


class HeaterWiring(_Strict):
    """Which supply output drives which heater."""

    target_output: int = Field(1, ge=1, le=4)
    coil_output: int = Field(2, ge=1, le=4)
    target_heater_ohm: float = Field(8.0, gt=0, description="for converting a power setpoint to volts")
    coil_heater_ohm: float = Field(8.0, gt=0)


class HeatedPart(_Strict):
    """How fast one heated part's temperature moves: the station's declared figures for the plan's lab-time
    estimate (``--dry-run``, the progress bar's ETA before the first wait has calibrated it), not for control."""

    settling_time_constant_s: float = Field(300.0, gt=0, le=86400.0, description=(
        "1/e time of the part's remaining temperature error while the regulation brings it to a new setpoint "
        "(read off a heating step's log: the time in which the error falls by a factor e near the setpoint)"))
    cooling_time_constant_s: float = Field(900.0, gt=0, le=86400.0, description=(
        "1/e time of the part's free cooling towards ambient with the heater off"))


class ThermalConfig(_Strict):
    """The heated parts' declared time constants (defaults: round values; declare the lab's own)."""

    coil: HeatedPart = HeatedPart()
    target: HeatedPart = HeatedPart(cooling_time_constant_s=600.0)
    ambient_c: float = Field(22.0, ge=-40.0, le=60.0, description="the lab's temperature, where parts cool to")
class LoopGains(_Strict):
    """PI(D) gains of one heater's temperature loop: heater watts per kelvin below the setpoint, the integral
    time and the derivative time. The defaults suit plates and boxes of minutes' time constant and about 1 K/W;
    another plant should be identified (``regulation.identify``) or given its own gains."""

    kp_w_per_k: float = Field(3.0, gt=0, le=1000.0, allow_inf_nan=False)
    ti_s: float = Field(400.0, ge=1.0, le=100_000.0, allow_inf_nan=False)
    td_s: float = Field(0.0, ge=0.0, le=100_000.0, allow_inf_nan=False,
                        description="derivative time (on the measurement, filtered); 0: PI")


class IdentificationConfig(_Strict):
    """A small heater step before the first setpoint, whose response proposes the loop's gains (docs/safety.md)."""

    enabled: bool = Field(True, description="identify each closed-loop heater before its first setpoint")
    step_fraction: float = Field(0.2, gt=0, le=0.5, allow_inf_nan=False,
                                 description="the step's power as a fraction of the heater's maximum power")
    rise_k: float = Field(3.0, ge=0.5, le=20.0, allow_inf_nan=False,
                          description="the step ends once the thermocouple has risen this much")
    timeout_s: float = Field(4 * 3600.0, ge=60.0, le=86400.0, allow_inf_nan=False,
                             description="give up (run failed) if the plant has not answered by then")
    margin_k: float = Field(10.0, ge=0.0, le=100.0, allow_inf_nan=False,
                            description="the step ends this far below the heater's over-temperature limit")


class RegulationConfig(_Strict):
    """How the heaters are regulated: PI gains per heater, and whether a step response proposes them."""

    target: LoopGains = LoopGains()
    coil: LoopGains = LoopGains()
    identify: IdentificationConfig = IdentificationConfig()


class SimulationConfig(_Strict):
    """The simulated lab behind the simulators, and how fast its time runs."""

    lab: LabConfig = LabConfig()
    real_time_factor: float = Field(0.0, ge=0, description="0: instant; 1: real time")
    pacing: bool = Field(True, description="keep the instruments' pauses between commands (in simulated time)")


class StationConfig(_Strict):
    """The lab: the four instruments, the heater wiring, safety limits; simulated or real."""

    name: str = "station"
    simulated: SimulationConfig | None = None
    bridge: InstrumentConfig = InstrumentConfig(driver="hm8118")
    slide: InstrumentConfig = InstrumentConfig(driver="grbl")
    scanner: InstrumentConfig = InstrumentConfig(driver="daq970a")
    heater: InstrumentConfig = InstrumentConfig(driver="hmp4040")
    heaters: HeaterWiring = HeaterWiring()
    safety: SafetyConfig = SafetyConfig()
    thermal: ThermalConfig = ThermalConfig()
    regulation: RegulationConfig = Field(RegulationConfig(), description="the heaters' PI gains and their "
                                         "identification by a step response before the first setpoint")
    sensor: SensorConfig | None = Field(None, description="the sensor on the slide, recorded in every run file: a "
                                        "shipped name (steel_target), a sensor YAML path, or the description inline; "
                                        "a simulated station without one uses its simulated lab's sensor")

    @field_validator("sensor", mode="before")
    @classmethod
    def _sensor_by_name(cls, value: Any) -> Any:
        """A shipped name or a path is loaded here, so errors in the sensor file name it."""
        if not isinstance(value, str):
            return value
        try:
            return load_sensor(value)
        except ConfigError as exc:
            raise ValueError(str(exc)) from None

    @model_validator(mode="after")
    def _one_sensor(self) -> StationConfig:
        """A simulated station simulates the sensor it names: one sensor, given once, for the lab and the runs."""
        if self.simulated is None:
            return self
        lab = self.simulated.lab
        if self.sensor is None:
            self.sensor = lab.sensor
        elif "sensor" in lab.model_fields_set and lab.sensor != self.sensor:
            raise ValueError("simulated.lab.sensor differs from the station's sensor; name the sensor once, "
                             "as the station's 'sensor'")
        else:
            self.simulated = self.simulated.model_copy(update={"lab": lab.model_copy(update={"sensor": self.sensor})})
        return self

    @field_validator(*ROLE_NAMES)
    @classmethod
    def _driver_fits_role(cls, instrument: InstrumentConfig, info: ValidationInfo) -> InstrumentConfig:
        role = str(info.field_name)
        allowed = drivers_for_role(role)
        if instrument.driver not in allowed:
            raise ValueError(f"driver {instrument.driver!r} cannot serve as {role}; "
                             f"allowed: {', '.join(allowed)}")
        return instrument

    @model_validator(mode="after")
    def _check(self) -> StationConfig:
        for role in ROLE_NAMES:
            instrument: InstrumentConfig = getattr(self, role)
            if role != "slide" and instrument.repeatability_um is not None:
                raise ValueError(f"{role}: repeatability_um belongs to the slide (its positioning repeatability), "
                                 f"not to the {role}")
            if self.simulated is None and instrument.link is None:
                raise ValueError(f"{role}: a real station needs a 'link' (serial url or visa resource)")
            _check_options(role, instrument)
        return self


def _check_options(role: str, instrument: InstrumentConfig) -> None:
    """Options are the driver's keyword arguments; an unknown one is named with those allowed."""
    import inspect

    parameters = inspect.signature(KINDS[instrument.driver].driver_class()).parameters
    allowed = [name for name, p in parameters.items() if p.kind is inspect.Parameter.KEYWORD_ONLY]
    unknown = sorted(set(instrument.options) - set(allowed))
    if unknown:
        raise ValueError(f"{role}: driver {instrument.driver!r} has no option {', '.join(map(repr, unknown))}; "
                         f"allowed: {', '.join(allowed) or 'none'}")
