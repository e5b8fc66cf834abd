"""Dispatch: every plan step has exactly one handler, and a new step needs only a dataclass and a handler."""

from __future__ import annotations

import gc
import inspect
from dataclasses import dataclass

import pytest

import ecds_lab.runner.handlers as handlers
from ecds_lab.config.experiment import BridgeConfig
from ecds_lab.data.columns import PLANNED_POINT
from ecds_lab.errors import EcdsLabError
from ecds_lab.runner import steps
from ecds_lab.runner.context import RunContext
from ecds_lab.runner.plan import Plan
from ecds_lab.runner.resume import OnResume
from ecds_lab.runner.runner import Runner
from ecds_lab.runner.steps import ConfigureBridge, MeasurePoint, PlanStep


def step_classes() -> list[type[PlanStep]]:
    """The concrete step classes (abstract bases such as PlanStep and HeaterStep have no handler)."""
    return [c for c in vars(steps).values() if isinstance(c, type) and issubclass(c, PlanStep)
            and not inspect.isabstract(c)]


@pytest.mark.parametrize("step_class", step_classes(), ids=lambda c: c.__name__)
def test_every_step_class_has_a_handler_and_a_resume_rule(step_class):
    assert step_class in handlers.HANDLERS
    assert isinstance(step_class.on_resume, OnResume)
    if step_class.on_resume is OnResume.LATEST_STATE:
        assert step_class.restores, f"{step_class.__name__} restores a state and must name it"


@dataclass(frozen=True)
class Pause(PlanStep):
    """A step the runner has never heard of: wait on the station's clock."""

    seconds: float

    def describe(self) -> str:
        return f"pause {self.seconds:g} s"


@pytest.fixture
def private_handlers(monkeypatch: pytest.MonkeyPatch) -> dict:
    """A copy of the handler table, so a test may register steps without touching the real one."""
    table = dict(handlers.HANDLERS)
    monkeypatch.setattr(handlers, "HANDLERS", table)
    return table


def test_a_new_step_runs_once_its_handler_is_registered(private_handlers, open_sim_station, rows_in_memory):
    @handlers.handles(Pause)
    def pause(run: RunContext, step: Pause) -> None:
        run.clock.sleep(step.seconds)

    station = open_sim_station()
    bridge = BridgeConfig(function="L-R", circuit="series", voltage_v=1.5, speed="slow", averages=1)
    plan = Plan("pause", "test", (ConfigureBridge(bridge), Pause(120.0), MeasurePoint(0, None, 1000.0)))
    writer = rows_in_memory
    status, error = Runner(station, plan, writer, progress=False).run()  # type: ignore[arg-type]
    assert (status, error) == ("completed", "")
    (row,) = writer.rows
    assert row["kind"] == PLANNED_POINT and row["point"] == 0 and row["freq_hz"] == 1000.0
    assert row["time_s"] >= 120.0


def test_a_step_without_a_handler_fails_the_run_naming_the_step(private_handlers, open_sim_station,
                                                                rows_in_memory):
    station = open_sim_station()
    status, error = Runner(station, Plan("p", "test", (Pause(1.0),)), rows_in_memory,  # type: ignore[arg-type]
                           progress=False).run()
    assert status == "failed"
    assert "no handler for plan step Pause" in error


def test_a_second_handler_for_the_same_step_is_refused(private_handlers):
    with pytest.raises(EcdsLabError, match="MeasurePoint already has a handler: measure_point"):
        handlers.handles(MeasurePoint)(lambda run, step: None)


def test_objects_alive_at_the_start_stay_out_of_collections_while_the_steps_run(private_handlers, open_sim_station,
                                                                                 rows_in_memory):
    """The runner freezes what is alive when the steps start (gc.freeze) and unfreezes it when they end, also
    when a step fails; a process that froze objects itself keeps its freeze."""
    seen: list[int] = []

    @handlers.handles(Pause)
    def pause(run: RunContext, step: Pause) -> None:
        seen.append(gc.get_freeze_count())
        if step.seconds < 0:
            raise EcdsLabError("a step that fails")

    station = open_sim_station()
    assert gc.get_freeze_count() == 0
    status, _ = Runner(station, Plan("p", "test", (Pause(1.0),)), rows_in_memory,  # type: ignore[arg-type]
                       progress=False).run()
    assert status == "completed" and seen[-1] > 0 and gc.get_freeze_count() == 0
    status, _ = Runner(station, Plan("p", "test", (Pause(-1.0),)), rows_in_memory,  # type: ignore[arg-type]
                       progress=False).run()
    assert status == "failed" and seen[-1] > 0 and gc.get_freeze_count() == 0
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        Runner(station, Plan("p", "test", (Pause(1.0),)), rows_in_memory, progress=False).run()  # type: ignore[arg-type]
        assert seen[-1] == frozen and gc.get_freeze_count() == frozen
    finally:
        gc.unfreeze()
