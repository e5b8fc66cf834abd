"""Experiment configuration: the four kinds the paper needs, validated before anything moves.

displacement_sweep  positions x frequencies, forward/backward/both, repeats
coil_heating        coil in air (slide parked) heated to setpoints; readings at steady states,
                    logging during ramps and the cool-down; optionally a sweep at each setpoint
target_heating      target heated to setpoints (closed loop on its thermocouple or fixed power),
                    a displacement sweep at each steady state
spectroscopy        a list of bridge frequencies at given coil temperatures (Table 2 fits)

Every duration, count and size is bounded (finite, positive where physical, an upper limit), and
a whole experiment whose plan would take more than ``MAX_READINGS`` bridge readings or, at the
least, more than ``MAX_DURATION_S`` is refused here, before anything moves (``size()``).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    TypeAdapter,
    field_validator,
    model_validator,
)

from ecds_lab.drivers.hm8118 import FREQUENCIES_HZ

MAX_READINGS = 10_000_000
MAX_DURATION_S = 7 * 86400.0
MAX_POSITIONS = 100_000
MAX_ITEMS = 100
"""Longest list of frequencies, setpoints or powers."""
TRAVEL_LIMIT_MM = 10_000.0
"""No slide is 10 m long: positions beyond this are typing errors (the station's travel is checked later)."""
MIN_STEP_MM = 0.001
"""1 um: finer than a lead-screw slide resolves."""

READING_S = {"fast": 0.1, "medium": 0.2, "slow": 0.6}
"""Nominal bridge measurement time per speed and average, for the duration estimate only."""
OVERHEAD_S = 0.5
"""Nominal time per reading for the frequency command, the thermocouple scan and the heater read-back."""
MOVE_MM_PER_S = 10.0
"""Nominal slide speed for the estimate: the GRBL driver's default feed, 600 mm/min."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


Frequencies = Annotated[list[float], Field(max_length=MAX_ITEMS)]
Temperatures = Annotated[list[Annotated[float, Field(ge=-100.0, le=1000.0)]], Field(max_length=MAX_ITEMS)]
PositionMm = Annotated[float, Field(ge=-TRAVEL_LIMIT_MM, le=TRAVEL_LIMIT_MM)]


@dataclass(frozen=True)
class PlanSize:
    """How big a plan is: its planned bridge readings and how long it takes (nominal, see READING_S).

    ``duration_s`` is the least it can take (each heating wait one steady-state window, no cool-down);
    ``worst_case_s`` lets every heating wait and cool-down run to its timeout.
    """

    readings: int
    duration_s: float
    worst_case_s: float

    def __add__(self, other: PlanSize) -> PlanSize:
        return PlanSize(self.readings + other.readings, self.duration_s + other.duration_s,
                        self.worst_case_s + other.worst_case_s)

    def times(self, count: int) -> PlanSize:
        return PlanSize(self.readings * count, self.duration_s * count, self.worst_case_s * count)

    def describe(self) -> str:
        """One line for ``--dry-run``: readings and estimated duration."""
        if self.worst_case_s > self.duration_s:
            return (f"{self.readings} bridge readings, estimated at least {format_duration(self.duration_s)}, "
                    f"up to {format_duration(self.worst_case_s)} if every heating wait runs to its timeout")
        return f"{self.readings} bridge readings, estimated {format_duration(self.duration_s)}"


def format_duration(seconds: float) -> str:
    """Seconds as the largest sensible unit: 45 s, 12.5 min, 3.2 h, 1.5 days."""
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.1f} {unit}"
    return f"{seconds:.0f} s"


def reading_s(bridge: BridgeConfig) -> float:
    """Lab seconds one bridge reading takes with ``bridge``'s speed and averaging, its overhead included."""
    return READING_S[bridge.speed] * bridge.averages + OVERHEAD_S


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

    positions_mm: Annotated[list[PositionMm], Field(max_length=MAX_POSITIONS)] | None = None
    start_mm: PositionMm | None = None
    stop_mm: PositionMm | None = None
    step_mm: float | None = Field(None, ge=MIN_STEP_MM, le=2 * TRAVEL_LIMIT_MM)
    frequencies_hz: Frequencies
    direction: Literal["forward", "backward", "both"] = "forward"
    repeats: int = Field(1, ge=1, le=1000)
    readings_per_point: int = Field(1, ge=1, le=100)
    settle_s: float = Field(1.0, ge=0, le=3600.0, description="pause after each move")

    _freqs = field_validator("frequencies_hz")(lambda cls, v: _check_frequencies(v))

    @model_validator(mode="after")
    def _positions_given_once(self) -> SweepConfig:
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
            if steps + 1 > MAX_POSITIONS:
                raise ValueError(f"step_mm {self.step_mm:g} gives {math.floor(steps) + 1} positions over the "
                                 f"{span:g} mm from start_mm to stop_mm; allowed: at most {MAX_POSITIONS} "
                                 f"positions (step_mm >= {span / (MAX_POSITIONS - 1):.3g} mm)")
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
        count = round(abs(self.stop_mm - self.start_mm) / self.step_mm) + 1
        return [round(float(v), 6) for v in np.linspace(self.start_mm, self.stop_mm, count)]

    def size(self, bridge: BridgeConfig) -> PlanSize:
        """Readings and nominal duration of the whole sweep (all repeats and directions)."""
        forward = self.positions()
        passes = 2 if self.direction == "both" else 1
        path_mm = sum(abs(b - a) for a, b in itertools.pairwise(forward))
        per_pass = PlanSize(len(forward) * len(self.frequencies_hz) * self.readings_per_point,
                            len(forward) * self.settle_s + path_mm / MOVE_MM_PER_S, 0.0)
        per_pass = PlanSize(per_pass.readings, per_pass.duration_s + per_pass.readings * reading_s(bridge), 0.0)
        total = per_pass.times(passes * self.repeats)
        return PlanSize(total.readings, total.duration_s, total.duration_s)


class SteadyState(_Strict):
    """Steady when the thermocouple's slope stays below a threshold over a window, near the setpoint."""

    slope_k_per_min: float = Field(0.1, gt=0, le=100.0)
    window_s: float = Field(300.0, gt=0, le=86400.0)
    tolerance_k: float = Field(1.0, gt=0, le=100.0)
    interval_s: float = Field(10.0, ge=1.0, le=3600.0, description="control and check period")
    timeout_s: float = Field(6 * 3600.0, gt=0, le=2 * 86400.0)

    @model_validator(mode="after")
    def _window_holds_readings(self) -> SteadyState:
        if self.window_s < 2 * self.interval_s:
            raise ValueError(f"window_s {self.window_s:g} s holds fewer than three readings taken every "
                             f"interval_s {self.interval_s:g} s; allowed: window_s >= 2 x interval_s")
        return self

    def wait(self) -> PlanSize:
        """One wait for a steady state: at least a window, at most the timeout."""
        return PlanSize(0, self.window_s, max(self.window_s, self.timeout_s))


class HeatingConfig(_Strict):
    """Setpoints and how they are reached."""

    setpoints_c: Annotated[Temperatures, Field(min_length=1)]
    control: Literal["temperature", "power"] = "temperature"
    powers_w: Annotated[list[Annotated[float, Field(ge=0, le=10_000.0)]], Field(max_length=MAX_ITEMS)] | None = (
        Field(None, description="with control: power, one per setpoint"))
    steady: SteadyState = SteadyState()
    log_interval_s: float = Field(60.0, ge=1.0, le=86400.0, description="bridge readings during ramps and cool-down")
    log_frequencies_hz: Frequencies | None = None
    cool_down_to_c: float | None = Field(None, ge=-100.0, le=1000.0,
                                         description="log the cool-down until this temperature")

    @model_validator(mode="after")
    def _powers(self) -> HeatingConfig:
        if self.control == "power" and (self.powers_w is None or len(self.powers_w) != len(self.setpoints_c)):
            raise ValueError("control: power needs powers_w with one power per setpoint")
        if self.log_frequencies_hz is not None:
            _check_frequencies(self.log_frequencies_hz)
        return self

    def waits(self) -> PlanSize:
        """Every steady-state wait, then the cool-down (0 at the least, its timeout at worst)."""
        cool = PlanSize(0, 0.0, self.steady.timeout_s if self.cool_down_to_c is not None else 0.0)
        return self.steady.wait().times(len(self.setpoints_c)) + cool


class _Experiment(_Strict):
    name: str = Field("experiment", max_length=200)
    description: str = Field("", max_length=10_000)
    operator_note: str = Field("", max_length=10_000)
    bridge: BridgeConfig = BridgeConfig()
    home_first: bool = True

    def size(self) -> PlanSize:
        """How many bridge readings the plan takes and how long it runs (nominal); see PlanSize."""
        raise NotImplementedError

    @model_validator(mode="after")
    def _plan_fits(self) -> _Experiment:
        size = self.size()
        fields = ", ".join(self._size_fields())
        if size.readings > MAX_READINGS:
            raise ValueError(f"the plan takes {size.readings} bridge readings (set by {fields}); "
                             f"allowed: at most {MAX_READINGS}")
        if size.duration_s > MAX_DURATION_S:
            raise ValueError(f"the plan takes at least {format_duration(size.duration_s)} with {size.readings} "
                             f"bridge readings (set by {fields}); allowed: at most {format_duration(MAX_DURATION_S)}")
        return self

    def _size_fields(self) -> list[str]:
        """The fields that make the plan long, for the message that refuses it."""
        fields = []
        for name in ("sweep", "heating"):
            part = getattr(self, name, None)
            if isinstance(part, SweepConfig):
                given = "positions_mm" if part.positions_mm is not None else "step_mm"
                fields += [f"sweep.{f}" for f in (given, "frequencies_hz", "direction", "repeats",
                                                  "readings_per_point", "settle_s")]
            elif isinstance(part, HeatingConfig):
                fields += ["heating.setpoints_c", "heating.steady.window_s"]
            elif isinstance(part, SteadyState):
                fields += ["coil_temperatures_c", "heating.window_s"]
        if not isinstance(getattr(self, "sweep", None), SweepConfig) and hasattr(self, "frequencies_hz"):
            fields += ["frequencies_hz", *(["readings"] if hasattr(self, "readings") else [])]
        return fields


class DisplacementSweep(_Experiment):
    kind: Literal["displacement_sweep"]
    sweep: SweepConfig

    def size(self) -> PlanSize:
        return self.sweep.size(self.bridge)


class CoilHeating(_Experiment):
    kind: Literal["coil_heating"]
    heating: HeatingConfig
    frequencies_hz: Frequencies
    readings: int = Field(3, ge=1, le=100, description="readings per frequency at each steady state")
    park_mm: PositionMm | None = Field(None, description="slide position during heating; null: leave it")
    coil_in_air: bool = Field(True, description="the target is removed: readings are recorded at x = inf")
    sweep: SweepConfig | None = Field(None, description="instead of parking: a sweep at each steady state")

    _freqs = field_validator("frequencies_hz")(lambda cls, v: _check_frequencies(v))

    def size(self) -> PlanSize:
        in_place = len(self.frequencies_hz) * self.readings
        at_steady = (self.sweep.size(self.bridge) if self.sweep is not None else
                     PlanSize(in_place, in_place * reading_s(self.bridge), in_place * reading_s(self.bridge)))
        return at_steady.times(len(self.heating.setpoints_c)) + self.heating.waits()


class TargetHeating(_Experiment):
    kind: Literal["target_heating"]
    heating: HeatingConfig
    sweep: SweepConfig

    def size(self) -> PlanSize:
        return self.sweep.size(self.bridge).times(len(self.heating.setpoints_c)) + self.heating.waits()


class Spectroscopy(_Experiment):
    kind: Literal["spectroscopy"]
    frequencies_hz: Frequencies
    coil_temperatures_c: Temperatures | None = Field(None, description="heated steps after the one at the start")
    heating: SteadyState = SteadyState()
    park_mm: PositionMm | None = None
    coil_in_air: bool = Field(True, description="the target is removed: readings are recorded at x = inf")

    _freqs = field_validator("frequencies_hz")(lambda cls, v: _check_frequencies(v))

    def size(self) -> PlanSize:
        steps = 1 + len(self.coil_temperatures_c or [])
        readings = len(self.frequencies_hz)
        spectrum = PlanSize(readings, readings * reading_s(self.bridge), readings * reading_s(self.bridge))
        return spectrum.times(steps) + self.heating.wait().times(steps - 1)


ExperimentConfig = Annotated[DisplacementSweep | CoilHeating | TargetHeating | Spectroscopy,
                             Field(discriminator="kind")]
EXPERIMENT_ADAPTER: TypeAdapter[ExperimentConfig] = TypeAdapter(ExperimentConfig)
