"""Resume: which steps of a plan a resumed run executes, from the rule each step declares."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import pytest

from ecds_lab.runner.plan import Plan, build_plan
from ecds_lab.runner.resume import OnResume
from ecds_lab.runner.resume import steps_to_run as resumed_steps
from ecds_lab.runner.session import load_experiment
from ecds_lab.runner.steps import (
    ConfigureBridge,
    ConfigureScanner,
    CoolDown,
    Home,
    MeasurePoint,
    PlanStep,
    SetHeater,
    WaitSteady,
)


def steps_to_run(plan, done: set[int]) -> list[int]:
    """Indexes of the plan's steps a Runner would execute with ``done`` already measured (no instrument)."""
    return [index for index, _ in resumed_steps(plan, done)]


@pytest.fixture
def small_heating_plan(yaml_copy):
    """Target heating at three setpoints with a two-position, two-frequency sweep at each."""
    def edit(data: dict) -> None:
        data["heating"]["setpoints_c"] = [22.0, 40.0, 60.0]
        data["sweep"].update(start_mm=20.0, stop_mm=30.0, step_mm=10.0, frequencies_hz=[500, 15000])

    return build_plan(load_experiment(yaml_copy("target_heating_copper.yaml", edit)))


def test_a_fresh_run_executes_every_step(small_heating_plan):
    assert steps_to_run(small_heating_plan, set()) == list(range(len(small_heating_plan.steps)))


def test_resume_skips_done_points_and_repeats_only_the_state_steps(small_heating_plan):
    plan = small_heating_plan
    steps = plan.steps
    per_setpoint = len(plan.points) // 3
    done = set(range(per_setpoint + 1))  # the first setpoint's sweep and one point of the second
    run = steps_to_run(plan, done)
    executed = [steps[i] for i in run]

    # the bridge and scanner are configured and the slide homed again, as in any run
    assert [type(s) for s in executed[:3]] == [ConfigureBridge, ConfigureScanner, Home]
    # only the heater state of the interrupted setpoint is re-established: no earlier setpoint, no done point
    heater_steps = [s for s in executed if isinstance(s, (SetHeater, WaitSteady))]
    assert [(type(s), s.setpoint_c) for s in heater_steps[:2]] == [(SetHeater, 40.0), (WaitSteady, 40.0)]
    assert all(s.setpoint_c != 22.0 for s in heater_steps)
    measured = [s.point for s in executed if isinstance(s, MeasurePoint)]
    assert measured == sorted(set(range(len(plan.points))) - done)
    # everything after the first missing point runs exactly as planned
    first_missing = next(i for i, s in enumerate(steps) if isinstance(s, MeasurePoint) and s.point not in done)
    assert [i for i in run if i >= first_missing] == list(range(first_missing, len(steps)))


def test_resume_with_every_point_done_only_makes_the_lab_safe(small_heating_plan):
    plan = small_heating_plan
    executed = [plan.steps[i] for i in steps_to_run(plan, {p.point for p in plan.points})]
    assert not any(isinstance(s, MeasurePoint) for s in executed)
    heater_steps = [s for s in executed if isinstance(s, (SetHeater, WaitSteady, CoolDown))]
    assert len(heater_steps) == 2 and heater_steps[0].setpoint_c is None and isinstance(heater_steps[1], CoolDown)


@dataclass(frozen=True)
class SetFan(PlanStep):
    """A step resume.py has never heard of, restoring a state of its own."""

    on_resume: ClassVar[OnResume] = OnResume.LATEST_STATE
    restores: ClassVar[str] = "fan speed"

    rpm: int

    def describe(self) -> str:
        return f"fan to {self.rpm} rpm"


def test_a_new_step_follows_the_resume_rule_it_declares():
    steps = (ConfigureScanner(), SetFan(100), SetHeater("coil", 40.0), SetFan(200), MeasurePoint(0, None, 500.0),
             SetFan(300), MeasurePoint(1, None, 500.0), MeasurePoint(2, None, 500.0))
    plan = Plan("fan", "test", steps)
    # before the first missing point: the scanner (always) and the latest fan and heater settings
    assert steps_to_run(plan, {0, 1}) == [0, 2, 5, 7]
    assert steps_to_run(plan, {0}) == [0, 2, 5, 6, 7]
    assert steps_to_run(plan, set()) == list(range(len(steps)))
