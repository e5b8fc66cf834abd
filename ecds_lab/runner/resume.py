"""Which steps of a plan a resumed run executes, decided by each step's declared ``on_resume``."""

from __future__ import annotations

from collections.abc import Iterator
from enum import Enum
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ecds_lab.runner.plan import Plan
    from ecds_lab.runner.steps import PlanStep


class OnResume(Enum):
    """How a step behaves when a run resumes before the first point it has not yet measured."""

    #: Sets up an instrument for this session (configure, home): executed in every run.
    ALWAYS = "always re-run"
    #: Restores a state (heater goal, slide position): of the steps before the resume point that set
    #: the same state, only the latest is re-run.
    LATEST_STATE = "re-run if it set the state in force at the resume point"
    #: Measures a planned point: skipped if the earlier run measured it.
    UNLESS_MEASURED = "skipped if its point was measured"


def steps_to_run(plan: Plan, done: set[int]) -> Iterator[tuple[int, PlanStep]]:
    """The plan's (index, step) to execute when the points in ``done`` are already measured.

    Before the first missing point each step follows its ``on_resume``; from there on everything
    runs as planned except points already measured. A fresh run (nothing done) executes every step.
    """
    steps = plan.steps
    if not done:  # a fresh run: the rules are for resuming
        yield from enumerate(steps)
        return
    first = next((i for i, s in enumerate(steps) if s.measures_point is not None and s.measures_point not in done),
                 len(steps))
    latest: dict[tuple[str, str], int] = {}
    for i, step in enumerate(steps[:first]):
        if step.on_resume is OnResume.LATEST_STATE:
            latest[step.state_key()] = i
    restore = set(latest.values())
    for i, step in enumerate(steps):
        if step.measures_point is not None and step.measures_point in done:
            continue
        if i < first and step.on_resume is OnResume.LATEST_STATE and i not in restore:
            continue
        yield i, step
