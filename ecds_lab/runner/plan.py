"""Plans: an experiment turned into a list of plain, inspectable steps.

A plan is data (frozen dataclasses), not code: ``ecds-lab run --dry-run`` prints it
before anything moves, the runner executes it step by step, and ``--resume`` uses
the point numbers to skip what an interrupted run already measured.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Union

from ecds_lab.config.experiment import (
    BridgeConfig, CoilHeating, DisplacementSweep, HeatingConfig, Spectroscopy, SweepConfig, TargetHeating,
)

Heater = Literal["target", "coil"]


@dataclass(frozen=True)
class ConfigureBridge:
    bridge: BridgeConfig

    def describe(self) -> str:
        b = self.bridge
        return f"configure bridge: {b.function} {b.circuit}, {b.voltage_v:g} V, {b.speed}, {b.averages} average(s)"


@dataclass(frozen=True)
class ConfigureScanner:
    def describe(self) -> str:
        return "configure the thermocouple scanner (type, reference junction, scan list)"


@dataclass(frozen=True)
class Home:
    def describe(self) -> str:
        return "home the slide"


@dataclass(frozen=True)
class Park:
    x_mm: float

    def describe(self) -> str:
        return f"park the slide at {self.x_mm:g} mm"


@dataclass(frozen=True)
class MeasurePoint:
    """Move (if needed), settle, set the frequency, read the bridge, temperatures and heater."""

    point: int
    x_mm: float | None
    freq_hz: float
    sweep: int = 0
    direction: Literal["forward", "backward", "none"] = "none"
    repeat: int = 0
    reading: int = 0
    settle_s: float = 0.0
    label: str = ""
    in_air: bool = False

    def describe(self) -> str:
        where = "coil in air" if self.in_air else "in place" if self.x_mm is None else f"x = {self.x_mm:g} mm ({self.direction})"
        return f"point {self.point}: {where}, {self.freq_hz:g} Hz, repeat {self.repeat}, reading {self.reading}"


@dataclass(frozen=True)
class SetHeater:
    """Set a heater's goal: a temperature (closed loop), a power, or off."""

    heater: Heater
    setpoint_c: float | None = None
    power_w: float | None = None

    def describe(self) -> str:
        if self.setpoint_c is None and self.power_w is None:
            return f"{self.heater} heater off"
        goal = f"{self.setpoint_c:g} C" if self.setpoint_c is not None else f"{self.power_w:g} W"
        return f"{self.heater} heater to {goal}"


@dataclass(frozen=True)
class WaitSteady:
    """Control the heater until its thermocouple is steady, logging the bridge meanwhile."""

    heater: Heater
    setpoint_c: float
    slope_k_per_min: float
    window_s: float
    tolerance_k: float
    interval_s: float
    timeout_s: float
    log_interval_s: float
    log_frequencies_hz: tuple[float, ...]

    def describe(self) -> str:
        return (f"wait until {self.heater} is steady at {self.setpoint_c:g} C "
                f"(< {self.slope_k_per_min:g} K/min over {self.window_s:g} s), logging every {self.log_interval_s:g} s")


@dataclass(frozen=True)
class CoolDown:
    """Heater off, log until the thermocouple falls below a temperature."""

    heater: Heater
    below_c: float
    interval_s: float
    timeout_s: float
    log_interval_s: float
    log_frequencies_hz: tuple[float, ...]

    def describe(self) -> str:
        return f"cool down: {self.heater} heater off, log until below {self.below_c:g} C"


Step = Union[ConfigureBridge, ConfigureScanner, Home, Park, MeasurePoint, SetHeater, WaitSteady, CoolDown]


@dataclass(frozen=True)
class Plan:
    """The steps of one experiment in order, and how many bridge points they measure."""

    name: str
    kind: str
    steps: tuple[Step, ...]

    @property
    def points(self) -> tuple[MeasurePoint, ...]:
        return tuple(s for s in self.steps if isinstance(s, MeasurePoint))

    def describe(self) -> str:
        lines = [f"plan '{self.name}' ({self.kind}): {len(self.steps)} steps, {len(self.points)} points"]
        lines += [f"{i:5d}  {step.describe()}" for i, step in enumerate(self.steps)]
        return "\n".join(lines)


class _Builder:
    """Accumulates steps and numbers the measured points."""

    def __init__(self) -> None:
        self.steps: list[Step] = []
        self.next_point = 0
        self.next_sweep = 0

    def add(self, step: Step) -> None:
        self.steps.append(step)

    def point(self, **fields: object) -> None:
        self.steps.append(MeasurePoint(point=self.next_point, **fields))  # type: ignore[arg-type]
        self.next_point += 1

    def sweep(self, sweep: SweepConfig, label: str = "") -> None:
        forward = sweep.positions()
        passes: list[tuple[str, list[float]]] = []
        if sweep.direction in ("forward", "both"):
            passes.append(("forward", forward))
        if sweep.direction in ("backward", "both"):
            passes.append(("backward", forward[::-1]))
        for repeat in range(sweep.repeats):
            for direction, positions in passes:
                for x in positions:
                    for f in sweep.frequencies_hz:
                        for reading in range(sweep.readings_per_point):
                            self.point(x_mm=x, freq_hz=f, sweep=self.next_sweep, direction=direction,
                                       repeat=repeat, reading=reading, settle_s=sweep.settle_s, label=label)
                self.next_sweep += 1

    def readings_in_place(self, frequencies: list[float], readings: int, label: str, in_air: bool) -> None:
        for f in frequencies:
            for reading in range(readings):
                self.point(x_mm=None, freq_hz=f, reading=reading, label=label, in_air=in_air)

    def heat(self, heater: Heater, heating: HeatingConfig, index: int, default_log: list[float]) -> None:
        setpoint = heating.setpoints_c[index]
        power = heating.powers_w[index] if heating.control == "power" and heating.powers_w else None
        self.add(SetHeater(heater, setpoint_c=None if power is not None else setpoint, power_w=power))
        st = heating.steady
        self.add(WaitSteady(heater, setpoint, st.slope_k_per_min, st.window_s, st.tolerance_k, st.interval_s,
                            st.timeout_s, heating.log_interval_s, tuple(heating.log_frequencies_hz or default_log)))

    def cool(self, heater: Heater, heating: HeatingConfig, default_log: list[float]) -> None:
        self.add(SetHeater(heater))
        if heating.cool_down_to_c is not None:
            st = heating.steady
            self.add(CoolDown(heater, heating.cool_down_to_c, st.interval_s, st.timeout_s,
                              heating.log_interval_s, tuple(heating.log_frequencies_hz or default_log)))


def build_plan(experiment: DisplacementSweep | CoilHeating | TargetHeating | Spectroscopy) -> Plan:
    """Turn a validated experiment into its plan."""
    b = _Builder()
    b.add(ConfigureBridge(experiment.bridge))
    b.add(ConfigureScanner())
    if experiment.home_first:
        b.add(Home())
    if isinstance(experiment, DisplacementSweep):
        b.sweep(experiment.sweep)
    elif isinstance(experiment, CoilHeating):
        if experiment.park_mm is not None:
            b.add(Park(experiment.park_mm))
        for i, setpoint in enumerate(experiment.heating.setpoints_c):
            b.heat("coil", experiment.heating, i, experiment.frequencies_hz)
            if experiment.sweep is not None:
                b.sweep(experiment.sweep, label=f"coil {setpoint:g} C")
                if experiment.park_mm is not None:
                    b.add(Park(experiment.park_mm))
            else:
                b.readings_in_place(experiment.frequencies_hz, experiment.readings, f"coil {setpoint:g} C",
                                    experiment.coil_in_air)
        b.cool("coil", experiment.heating, experiment.frequencies_hz)
    elif isinstance(experiment, TargetHeating):
        for i, setpoint in enumerate(experiment.heating.setpoints_c):
            b.heat("target", experiment.heating, i, experiment.sweep.frequencies_hz)
            b.sweep(experiment.sweep, label=f"target {setpoint:g} C")
        b.cool("target", experiment.heating, experiment.sweep.frequencies_hz)
    elif isinstance(experiment, Spectroscopy):
        if experiment.park_mm is not None:
            b.add(Park(experiment.park_mm))
        for temperature in [None, *(experiment.coil_temperatures_c or [])]:
            if temperature is not None:
                st = experiment.heating
                b.add(SetHeater("coil", setpoint_c=temperature))
                b.add(WaitSteady("coil", temperature, st.slope_k_per_min, st.window_s, st.tolerance_k,
                                 st.interval_s, st.timeout_s, 1e9, ()))
            label = "ambient" if temperature is None else f"coil {temperature:g} C"
            b.readings_in_place(experiment.frequencies_hz, 1, label, experiment.coil_in_air)
        if experiment.coil_temperatures_c:
            b.add(SetHeater("coil"))
    return Plan(experiment.name, experiment.kind, tuple(b.steps))
