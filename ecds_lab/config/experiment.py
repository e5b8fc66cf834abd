"""Experiment configuration: the four kinds the paper needs, validated before anything moves.

displacement_sweep  positions x frequencies, forward/backward/both, repeats
coil_heating        coil in air (slide parked) heated to setpoints; readings at steady states,
                    logging during ramps and the cool-down; optionally a sweep at each setpoint
target_heating      target heated to setpoints (closed loop on its thermocouple or fixed power),
                    a displacement sweep at each steady state
spectroscopy        a list of bridge frequencies at given coil temperatures (Table 2 fits)
"""

from __future__ import annotations

import math
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, field_validator, model_validator

from ecds_lab.drivers.hm8118 import FREQUENCIES_HZ


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


def _check_frequencies(values: list[float]) -> list[float]:
    bad = [f for f in values if f not in FREQUENCIES_HZ]
    if bad:
        raise ValueError(f"{', '.join(f'{f:g}' for f in bad)} Hz not available on the HM8118; "
                         f"allowed: {', '.join(str(f) for f in FREQUENCIES_HZ)}")
    if not values:
        raise ValueError("at least one frequency is needed")
    return values


class BridgeConfig(_Strict):
    """Bridge settings for the run (paper: L-R series, 1.5 V, slow)."""

    function: Literal["L-R"] = "L-R"
    circuit: Literal["series", "parallel"] = "series"
    voltage_v: float = Field(1.5, ge=0.05, le=1.5)
    speed: Literal["fast", "medium", "slow"] = "slow"
    averages: int = Field(1, ge=1, le=99)


class SweepConfig(_Strict):
    """Where and how to measure: positions (list, or start/stop/step) x frequencies."""

    positions_mm: list[float] | None = None
    start_mm: float | None = None
    stop_mm: float | None = None
    step_mm: float | None = Field(None, gt=0)
    frequencies_hz: list[float]
    direction: Literal["forward", "backward", "both"] = "forward"
    repeats: int = Field(1, ge=1, le=1000)
    readings_per_point: int = Field(1, ge=1, le=100)
    settle_s: float = Field(1.0, ge=0)

    _freqs = field_validator("frequencies_hz")(lambda cls, v: _check_frequencies(v))

    @model_validator(mode="after")
    def _positions_given_once(self) -> "SweepConfig":
        ranged = (self.start_mm, self.stop_mm, self.step_mm)
        if self.positions_mm is None and None in ranged:
            raise ValueError("give positions_mm, or start_mm, stop_mm and step_mm")
        if self.positions_mm is not None and any(v is not None for v in ranged):
            raise ValueError("give either positions_mm or start_mm/stop_mm/step_mm, not both")
        if self.positions_mm is not None and not self.positions_mm:
            raise ValueError("positions_mm is empty")
        if self.positions_mm is None:
            assert self.start_mm is not None and self.stop_mm is not None and self.step_mm is not None
            span = abs(self.stop_mm - self.start_mm)
            steps = span / self.step_mm
            if abs(steps - round(steps)) > 1e-6 * max(1.0, steps):
                near = sorted({span / n for n in (max(1, math.floor(steps)), math.ceil(steps))}, reverse=True)
                raise ValueError(f"step_mm {self.step_mm:g} does not divide the {span:g} mm from start_mm to stop_mm "
                                 f"(positions run from start_mm to stop_mm inclusive); allowed: a step that divides "
                                 f"it, e.g. {' or '.join(f'{v:g}' for v in near)} mm")
        return self

    def positions(self) -> list[float]:
        """The forward list of positions in mm (start..stop inclusive)."""
        if self.positions_mm is not None:
            return list(self.positions_mm)
        assert self.start_mm is not None and self.stop_mm is not None and self.step_mm is not None
        count = int(round(abs(self.stop_mm - self.start_mm) / self.step_mm)) + 1
        return [round(float(v), 6) for v in np.linspace(self.start_mm, self.stop_mm, count)]


class SteadyState(_Strict):
    """Steady when the thermocouple's slope stays below a threshold over a window, near the setpoint."""

    slope_k_per_min: float = Field(0.1, gt=0)
    window_s: float = Field(300.0, gt=0)
    tolerance_k: float = Field(1.0, gt=0)
    interval_s: float = Field(10.0, gt=0, description="control and check period")
    timeout_s: float = Field(6 * 3600.0, gt=0)


class HeatingConfig(_Strict):
    """Setpoints and how they are reached."""

    setpoints_c: list[float] = Field(min_length=1)
    control: Literal["temperature", "power"] = "temperature"
    powers_w: list[float] | None = Field(None, description="with control: power, one per setpoint")
    steady: SteadyState = SteadyState()
    log_interval_s: float = Field(60.0, gt=0, description="bridge readings during ramps and cool-down")
    log_frequencies_hz: list[float] | None = None
    cool_down_to_c: float | None = Field(None, description="log the cool-down until this temperature")

    @model_validator(mode="after")
    def _powers(self) -> "HeatingConfig":
        if self.control == "power" and (self.powers_w is None or len(self.powers_w) != len(self.setpoints_c)):
            raise ValueError("control: power needs powers_w with one power per setpoint")
        if self.log_frequencies_hz is not None:
            _check_frequencies(self.log_frequencies_hz)
        return self


class _Experiment(_Strict):
    name: str = "experiment"
    description: str = ""
    operator_note: str = ""
    bridge: BridgeConfig = BridgeConfig()
    home_first: bool = True


class DisplacementSweep(_Experiment):
    kind: Literal["displacement_sweep"]
    sweep: SweepConfig


class CoilHeating(_Experiment):
    kind: Literal["coil_heating"]
    heating: HeatingConfig
    frequencies_hz: list[float]
    readings: int = Field(3, ge=1, le=100, description="readings per frequency at each steady state")
    park_mm: float | None = Field(None, description="slide position during heating; null: leave it")
    coil_in_air: bool = Field(True, description="the target is removed: readings are recorded at x = inf")
    sweep: SweepConfig | None = Field(None, description="instead of parking: a sweep at each steady state")

    _freqs = field_validator("frequencies_hz")(lambda cls, v: _check_frequencies(v))


class TargetHeating(_Experiment):
    kind: Literal["target_heating"]
    heating: HeatingConfig
    sweep: SweepConfig


class Spectroscopy(_Experiment):
    kind: Literal["spectroscopy"]
    frequencies_hz: list[float]
    coil_temperatures_c: list[float] | None = Field(None, description="heated steps after the one at the start")
    heating: SteadyState = SteadyState()
    park_mm: float | None = None
    coil_in_air: bool = Field(True, description="the target is removed: readings are recorded at x = inf")

    _freqs = field_validator("frequencies_hz")(lambda cls, v: _check_frequencies(v))


ExperimentConfig = Annotated[Union[DisplacementSweep, CoilHeating, TargetHeating, Spectroscopy],
                             Field(discriminator="kind")]
EXPERIMENT_ADAPTER: TypeAdapter[ExperimentConfig] = TypeAdapter(ExperimentConfig)
