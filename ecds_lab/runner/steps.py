"""The steps a plan is made of: frozen dataclasses that say what to do, never how.

Each step class declares how it behaves when a run is resumed (``on_resume``) and, if it
restores a state, which one (``restores``). How a step is executed lives in
:mod:`ecds_lab.runner.handlers`; a new kind of step is a class here plus one handler there.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar, Literal

from ecds_lab.config.experiment import BridgeConfig
from ecds_lab.runner.resume import OnResume
from ecds_lab.runner.steady_state import SteadyState

Heater = Literal["target", "coil"]


class PlanStep(ABC):
    """What every step offers the runner: a one-line description and its behaviour on resume."""

    on_resume: ClassVar[OnResume] = OnResume.ALWAYS
    #: For LATEST_STATE steps: the state they set (steps that set the same state replace each other).
    restores: ClassVar[str] = ""

    @abstractmethod
    def describe(self) -> str:
        """One line for the dry run and the log."""

    @property
    def measures_point(self) -> int | None:
        """The planned point this step measures, if it measures one."""
        return None

    def state_key(self) -> tuple[str, str]:
        """Which state a LATEST_STATE step sets: the kind of state, and what it belongs to ("" for the station)."""
        return self.restores, ""


@dataclass(frozen=True)
class BridgeLog:
    """Bridge readings taken while waiting on a heater: every ``interval_s``, at each frequency."""

    interval_s: float
    frequencies_hz: tuple[float, ...]

    def describe(self) -> str:
        if not self.frequencies_hz:
            return "no bridge readings"
        frequencies = ", ".join(f"{f:g}" for f in self.frequencies_hz)
        return f"logging the bridge every {self.interval_s:g} s at {frequencies} Hz"


@dataclass(frozen=True)
class ConfigureBridge(PlanStep):
    """Set the bridge's function, circuit, test voltage, speed and averaging for the run."""

    bridge: BridgeConfig

    def describe(self) -> str:
        b = self.bridge
        return f"configure bridge: {b.function} {b.circuit}, {b.voltage_v:g} V, {b.speed}, {b.averages} average(s)"


@dataclass(frozen=True)
class ConfigureScanner(PlanStep):
    """Set up the thermocouple channels (type, reference junction, scan list)."""

    def describe(self) -> str:
        return "configure the thermocouple scanner (type, reference junction, scan list)"


@dataclass(frozen=True)
class Home(PlanStep):
    """Home the slide: its position is unknown until the next move."""

    def describe(self) -> str:
        return "home the slide"


@dataclass(frozen=True)
class Park(PlanStep):
    """Move the slide to a fixed position (e.g. coil away from the target while heating)."""

    on_resume: ClassVar[OnResume] = OnResume.LATEST_STATE
    restores: ClassVar[str] = "slide position"

    x_mm: float

    def describe(self) -> str:
        return f"park the slide at {self.x_mm:g} mm"


@dataclass(frozen=True)
class MeasurePoint(PlanStep):
    """Move (if needed), settle, set the frequency, read the bridge, temperatures and heater."""

    on_resume: ClassVar[OnResume] = OnResume.UNLESS_MEASURED

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

    @property
    def measures_point(self) -> int | None:
        return self.point

    def describe(self) -> str:
        where = ("coil in air" if self.in_air else "in place" if self.x_mm is None
                 else f"x = {self.x_mm:g} mm ({self.direction})")
        return (f"planned reading {self.point}: {where}, {self.freq_hz:g} Hz, repeat {self.repeat}, "
                f"reading {self.reading} at this position and frequency")


@dataclass(frozen=True)
class HeaterStep(PlanStep):
    """A step about one heater: the state it restores on resume is that heater's."""

    heater: Heater

    def state_key(self) -> tuple[str, str]:
        return self.restores, self.heater


@dataclass(frozen=True)
class SetHeater(HeaterStep):
    """Set a heater's goal: a temperature (closed loop), a power, or off."""

    on_resume: ClassVar[OnResume] = OnResume.LATEST_STATE
    restores: ClassVar[str] = "heater goal"

    setpoint_c: float | None = None
    power_w: float | None = None

    def describe(self) -> str:
        if self.setpoint_c is None and self.power_w is None:
            return f"{self.heater} heater off"
        goal = f"{self.setpoint_c:g} C" if self.setpoint_c is not None else f"{self.power_w:g} W"
        return f"{self.heater} heater to {goal}"


def _logging(log: BridgeLog | None) -> str:
    """What a heater step logs meanwhile, in words."""
    return log.describe() if log is not None else "no bridge readings"


@dataclass(frozen=True)
class WaitSteady(HeaterStep):
    """Control the heater until its thermocouple is steady at the setpoint, logging the bridge meanwhile."""

    on_resume: ClassVar[OnResume] = OnResume.LATEST_STATE
    restores: ClassVar[str] = "heater temperature"

    setpoint_c: float
    steady: SteadyState
    log: BridgeLog | None = None

    def describe(self) -> str:
        return (f"wait until {self.heater} is steady at {self.setpoint_c:g} C ({self.steady.describe()}); "
                f"{_logging(self.log)}")


@dataclass(frozen=True)
class CoolDown(HeaterStep):
    """Heater off, log until the thermocouple falls below a temperature (``timeout_s`` None: no limit)."""

    on_resume: ClassVar[OnResume] = OnResume.LATEST_STATE
    restores: ClassVar[str] = "heater temperature"

    below_c: float
    check_interval_s: float
    timeout_s: float | None
    log: BridgeLog | None = None

    def describe(self) -> str:
        return f"cool down: {self.heater} heater off, wait until below {self.below_c:g} C; {_logging(self.log)}"


@dataclass(frozen=True)
class IdentifyPlant(HeaterStep):
    """A small power step of one heater, before its first setpoint: the response proposes its loop's gains
    (:mod:`ecds_lab.runner.identification`). The heater is off again at the end."""

    step_fraction: float
    rise_k: float
    margin_k: float
    check_interval_s: float
    timeout_s: float

    def describe(self) -> str:
        return (f"identify the {self.heater} heater: {self.step_fraction:.0%} of its power until it rises "
                f"{self.rise_k:g} K (stopping {self.margin_k:g} K below its over-temperature limit), then off until "
                f"it turns; the response proposes its PID gains (checked every {self.check_interval_s:g} s, give up "
                f"after {self.timeout_s:g} s)")


@dataclass(frozen=True)
class CheckHold(HeaterStep):
    """Close the record of how the heater held its setpoint since it was steady: range and drift of its
    thermocouple, judged against ``tolerance_k`` (out of tolerance: a warning and a note in the run file)."""

    setpoint_c: float
    tolerance_k: float

    def describe(self) -> str:
        return (f"check that {self.heater} stayed within {self.tolerance_k:g} K of {self.setpoint_c:g} C "
                "while the readings were taken (drift recorded)")
