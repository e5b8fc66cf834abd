"""How each kind of plan step is executed: one handler per step class, found through ``HANDLERS``.

A new kind of step is a dataclass in :mod:`ecds_lab.runner.steps` plus a function here
decorated with ``@handles(ThatStep)``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any, TypeVar

from ecds_lab.data.columns import PLANNED_POINT
from ecds_lab.errors import EcdsLabError
from ecds_lab.instruments.interfaces import BridgeSettings
from ecds_lab.runner.context import RunContext
from ecds_lab.runner.heater_control import HeaterGoal
from ecds_lab.runner.identification import identify
from ecds_lab.runner.regulation import regulate
from ecds_lab.runner.steady_state import SteadinessWindow
from ecds_lab.runner.steps import (
    CheckHold,
    ConfigureBridge,
    ConfigureScanner,
    CoolDown,
    Home,
    IdentifyPlant,
    MeasurePoint,
    Park,
    PlanStep,
    SetHeater,
    WaitSteady,
)
from ecds_lab.runner.temperature_hold import HoldTracker

log = logging.getLogger("ecds_lab.runner")

S = TypeVar("S", bound=PlanStep)
Handler = Callable[[RunContext, Any], None]

#: Step class -> the function that executes it.
HANDLERS: dict[type[PlanStep], Handler] = {}


def handles(step_class: type[S]) -> Callable[[Callable[[RunContext, S], None]], Callable[[RunContext, S], None]]:
    """Register the decorated function as the handler of ``step_class`` (one handler per class)."""
    def register(handler: Callable[[RunContext, S], None]) -> Callable[[RunContext, S], None]:
        if step_class in HANDLERS:
            raise EcdsLabError(f"{step_class.__name__} already has a handler: {HANDLERS[step_class].__name__}")
        HANDLERS[step_class] = handler
        return handler
    return register


def handler_for(step: PlanStep) -> Handler:
    """The handler of a step; EcdsLabError naming the step if it has none."""
    try:
        return HANDLERS[type(step)]
    except KeyError:
        raise EcdsLabError(f"no handler for plan step {type(step).__name__} ({step!r}); "
                           "register one with @handles in ecds_lab/runner/handlers.py") from None


@handles(ConfigureBridge)
def configure_bridge(run: RunContext, step: ConfigureBridge) -> None:
    b = step.bridge
    run.station.bridge.configure(BridgeSettings(b.function, b.circuit, b.voltage_v, b.speed, b.averages))


@handles(ConfigureScanner)
def configure_scanner(run: RunContext, step: ConfigureScanner) -> None:
    run.station.scanner.configure()


@handles(Home)
def home(run: RunContext, step: Home) -> None:
    run.position.home()


@handles(Park)
def park(run: RunContext, step: Park) -> None:
    run.tend_heaters()
    run.position.move_to(step.x_mm)
    run.tend_heaters()


@handles(MeasurePoint)
def measure_point(run: RunContext, step: MeasurePoint) -> None:
    """Move and settle if the point is elsewhere, then record it; a heater holding a setpoint is regulated
    before and after the move, through the settling and between readings."""
    run.tend_heaters()
    if step.x_mm is not None and run.position.move_to(step.x_mm):
        run.tend_heaters()
        run.sleep(step.settle_s)
    run.record(step.freq_hz, PLANNED_POINT, step)
    run.progress.point_measured()


@handles(SetHeater)
def set_heater(run: RunContext, step: SetHeater) -> None:
    run.heaters.set_goal(step.heater, HeaterGoal(step.setpoint_c, step.power_w),
                         temperatures=lambda: run.thermocouples.read(fresh=True))


@handles(WaitSteady)
def wait_steady(run: RunContext, step: WaitSteady) -> None:
    window = SteadinessWindow(step.steady, step.setpoint_c)

    def steady(now: float, temperatures: dict[str, float]) -> bool:
        value = temperatures[step.heater]
        run.progress.note(f"{step.heater} {value:.1f} C -> {step.setpoint_c:g} C")
        return window.add(now, value)

    run.heaters.period_s = step.steady.check_interval_s
    regulate(run, step.heater, check_interval_s=step.steady.check_interval_s, timeout_s=step.steady.timeout_s,
             bridge_log=step.log, finished=steady, failure=f"not steady at {step.setpoint_c:g} C")
    tracker = HoldTracker(step.heater, step.setpoint_c, step.steady.tolerance_k)
    tracker.observe(run.clock.now() - run.t0, run.thermocouples.latest)
    run.holding[step.heater] = tracker


@handles(IdentifyPlant)
def identify_plant(run: RunContext, step: IdentifyPlant) -> None:
    identify(run, step)


@handles(CheckHold)
def check_hold(run: RunContext, step: CheckHold) -> None:
    """Close the heater's hold at this setpoint (if one is open: a resumed run may have none) and judge it."""
    tracker = run.holding.get(step.heater)
    if tracker is None or tracker.setpoint_c != step.setpoint_c:
        return
    del run.holding[step.heater]
    record = tracker.close()
    run.holds.append(record)
    log.info("%s", record.describe())
    if not record.within_tolerance:
        run.notes.append(f"WARNING: {record.describe()}; the readings are kept, each with its measured temperatures")


@handles(CoolDown)
def cool_down(run: RunContext, step: CoolDown) -> None:
    regulate(run, step.heater, check_interval_s=step.check_interval_s, timeout_s=step.timeout_s,
             bridge_log=step.log, finished=lambda now, temperatures: temperatures[step.heater] < step.below_c,
             failure=f"still at or above {step.below_c:g} C")
