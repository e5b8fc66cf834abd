"""Plans: an experiment turned into a list of plain, inspectable steps.

A plan is data (frozen dataclasses, :mod:`~ecds_lab.runner.steps`), not code: ``ecds-lab run
--dry-run`` prints it before anything moves, the runner executes it step by step, and ``--resume``
skips what an interrupted run already measured, following the rule each step declares.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ecds_lab.config.experiment import (
    CoilHeating,
    DisplacementSweep,
    HeatingConfig,
    Spectroscopy,
    SweepConfig,
    TargetHeating,
)
from ecds_lab.config.experiment import SteadyState as SteadyStateConfig
from ecds_lab.config.station import RegulationConfig, ThermalConfig
from ecds_lab.runner.steady_state import SteadyState
from ecds_lab.runner.steps import (
    BridgeLog,
    CheckHold,
    ConfigureBridge,
    ConfigureScanner,
    CoolDown,
    Heater,
    Home,
    IdentifyPlant,
    MeasurePoint,
    Park,
    PlanStep,
    SetHeater,
    WaitSteady,
)


@dataclass(frozen=True)
class Plan:
    """The steps of one experiment in order, how many planned points they measure, and the station's thermal
    figures its lab-time estimate uses (runner/progress.py)."""

    name: str
    kind: str
    steps: tuple[PlanStep, ...]
    thermal: ThermalConfig = field(default_factory=ThermalConfig)

    @property
    def points(self) -> tuple[MeasurePoint, ...]:
        return tuple(s for s in self.steps if isinstance(s, MeasurePoint))

    @property
    def coil_in_air(self) -> bool:
        """Every planned reading is taken with the coil in air: the run records its logged readings at x = inf too."""
        return bool(self.points) and all(p.in_air for p in self.points)

    def describe(self) -> str:
        lines = [f"plan '{self.name}' ({self.kind}): {len(self.steps)} steps, {len(self.points)} planned readings"]
        lines += [f"{i:5d}  {step.describe()}" for i, step in enumerate(self.steps)]
        return "\n".join(lines) + "\n" + self.summary()

    def summary(self) -> str:
        """Steps by kind, readings, estimated duration, temperature range and slide travel."""
        from ecds_lab.runner.progress import summary

        return summary(self)


def steady_state(config: SteadyStateConfig) -> SteadyState:
    """The steady-state criterion of an experiment's configuration, as a plan value."""
    return SteadyState(slope_k_per_min=config.slope_k_per_min, window_s=config.window_s,
                       tolerance_k=config.tolerance_k, check_interval_s=config.interval_s, timeout_s=config.timeout_s)


def _bridge_log(heating: HeatingConfig, default_frequencies_hz: list[float]) -> BridgeLog:
    return BridgeLog(heating.log_interval_s, tuple(heating.log_frequencies_hz or default_frequencies_hz))


class _Builder:
    """Accumulates steps and numbers the measured points."""

    def __init__(self, regulation: RegulationConfig | None) -> None:
        self.steps: list[PlanStep] = []
        self.next_point = 0
        self.next_sweep = 0
        self.identify = regulation.identify if regulation is not None and regulation.identify.enabled else None
        self.identified: set[Heater] = set()

    def add(self, step: PlanStep) -> None:
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

    def to_setpoint(self, heater: Heater, setpoint_c: float, steady: SteadyStateConfig) -> None:
        """The heater to a closed-loop setpoint, identified first if the station asks and it is the first."""
        if self.identify is not None and heater not in self.identified:
            i = self.identify
            self.add(IdentifyPlant(heater, i.step_fraction, i.rise_k, i.margin_k, steady.interval_s, i.timeout_s))
            self.identified.add(heater)
        self.add(SetHeater(heater, setpoint_c=setpoint_c))

    def heat(self, heater: Heater, heating: HeatingConfig, index: int, default_log: list[float]) -> None:
        setpoint = heating.setpoints_c[index]
        power = heating.powers_w[index] if heating.control == "power" and heating.powers_w else None
        if power is None:
            self.to_setpoint(heater, setpoint, heating.steady)
        else:
            self.add(SetHeater(heater, power_w=power))
        self.add(WaitSteady(heater, setpoint, steady_state(heating.steady), _bridge_log(heating, default_log)))

    def check_hold(self, heater: Heater, setpoint_c: float, steady: SteadyStateConfig) -> None:
        self.add(CheckHold(heater, setpoint_c, steady.tolerance_k))

    def cool(self, heater: Heater, heating: HeatingConfig, default_log: list[float]) -> None:
        self.add(SetHeater(heater))
        if heating.cool_down_to_c is not None:
            st = heating.steady
            self.add(CoolDown(heater, heating.cool_down_to_c, st.interval_s, st.timeout_s,
                              _bridge_log(heating, default_log)))


def build_plan(experiment: DisplacementSweep | CoilHeating | TargetHeating | Spectroscopy,
               thermal: ThermalConfig | None = None, regulation: RegulationConfig | None = None) -> Plan:
    """Turn a validated experiment into its plan; ``thermal``: the station's figures for its time estimate; with
    the station's ``regulation`` whose identification is enabled, each closed-loop heater is identified before
    its first setpoint."""
    b = _Builder(regulation)
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
                b.check_hold("coil", setpoint, experiment.heating.steady)
                if experiment.park_mm is not None:
                    b.add(Park(experiment.park_mm))
            else:
                b.readings_in_place(experiment.frequencies_hz, experiment.readings, f"coil {setpoint:g} C",
                                    experiment.coil_in_air)
                b.check_hold("coil", setpoint, experiment.heating.steady)
        b.cool("coil", experiment.heating, experiment.frequencies_hz)
    elif isinstance(experiment, TargetHeating):
        for i, setpoint in enumerate(experiment.heating.setpoints_c):
            b.heat("target", experiment.heating, i, experiment.sweep.frequencies_hz)
            b.sweep(experiment.sweep, label=f"target {setpoint:g} C")
            b.check_hold("target", setpoint, experiment.heating.steady)
        b.cool("target", experiment.heating, experiment.sweep.frequencies_hz)
    elif isinstance(experiment, Spectroscopy):
        if experiment.park_mm is not None:
            b.add(Park(experiment.park_mm))
        for temperature in [None, *(experiment.coil_temperatures_c or [])]:
            if temperature is not None:
                b.to_setpoint("coil", temperature, experiment.heating)
                b.add(WaitSteady("coil", temperature, steady_state(experiment.heating)))
            label = "ambient" if temperature is None else f"coil {temperature:g} C"
            b.readings_in_place(experiment.frequencies_hz, 1, label, experiment.coil_in_air)
            if temperature is not None:
                b.check_hold("coil", temperature, experiment.heating)
        if experiment.coil_temperatures_c:
            b.add(SetHeater("coil"))
    return Plan(experiment.name, experiment.kind, tuple(b.steps), thermal or ThermalConfig())
