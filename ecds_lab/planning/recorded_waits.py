"""The heater waits a campaign's run files recorded: which part, from what temperature to what goal, its
thermocouple against time, and (a wait for a steady setpoint) how long the run waited.

A run file keeps its experiment and station (``experiment_yaml``, ``station_yaml``), so the run's plan is rebuilt
(``runner.plan.build_plan``) and each logged row is tied to its step (the ``step`` column): a ``WaitSteady`` or
``CoolDown`` that logs bridge readings has its heated part's thermocouple at every log, the first at the wait's
start (a wait on a heater driven at a fixed power is not its regulation's answer, and is left out). A steady wait
ends where the run starts judging the hold at its setpoint (``temperature_holds``'s ``start_s``), so its duration
is measured, not the time of its last log. A CSV, or a run file without its configuration, records no waits
(``recorded_runs``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import yaml

from ecds_lab.config.experiment import ExperimentConfig
from ecds_lab.config.station import StationConfig
from ecds_lab.data.columns import LOGGED_POINT
from ecds_lab.errors import EcdsLabError
from ecds_lab.planning.recorded_runs import RecordedRun
from ecds_lab.runner.plan import build_plan
from ecds_lab.runner.steady_state import SteadyState
from ecds_lab.runner.steps import CoolDown, SetHeater, WaitSteady
from ecds_lab.storage.reader import RunFile

#: A log this close after the hold's start (s) still belongs to the wait (the clock's rounding).
_SLACK_S = 1e-6


@dataclass(frozen=True)
class RecordedWait:
    """One heater wait of a run: the part, heating to a setpoint or cooling below a temperature, the thermocouple
    at each log (times from the wait's start), the room it cooled towards, and the steady wait's duration."""

    heater: str
    cooling: bool
    goal_c: float
    times_s: np.ndarray
    temps_c: np.ndarray
    ambient_c: float
    #: a steady wait: its criterion and how long the run waited (None: a cool-down, or a wait whose end is unknown)
    steady: SteadyState | None = None
    duration_s: float | None = None

    @property
    def start_c(self) -> float:
        return float(self.temps_c[0])


def recorded_waits(runs: Sequence[RecordedRun]) -> list[RecordedWait]:
    """Every heater wait that logged readings in the campaign's ``runs`` (``recorded_runs``), in file and step
    order."""
    waits: list[RecordedWait] = []
    for recorded in runs:
        try:
            waits.extend(_waits_of(recorded.run, recorded.experiment))
        except (EcdsLabError, ValueError, yaml.YAMLError):
            continue  # a run whose station this ecds-lab cannot rebuild the plan with
    return waits


def _waits_of(run: RunFile, experiment: ExperimentConfig) -> list[RecordedWait]:
    station = StationConfig.model_validate(yaml.safe_load(run.metadata.get("station_yaml", "")))
    plan = build_plan(experiment, station.thermal, station.regulation)
    holds = json.loads(run.metadata.get("temperature_holds", "") or "[]")
    logged = run.column("kind") == LOGGED_POINT
    steps, times = run.column("step"), run.column("time_s")
    out = []
    powered: dict[str, bool] = {}  # per heater: driven at a fixed power (no regulation answering a setpoint)
    for index, step in enumerate(plan.steps):
        if isinstance(step, SetHeater):
            powered[step.heater] = step.power_w is not None
        if not isinstance(step, WaitSteady | CoolDown) or step.log is None or not step.log.frequencies_hz:
            continue
        if isinstance(step, WaitSteady) and powered.get(step.heater, False):
            continue
        rows = logged & (steps == index) & (run.column("freq_hz") == step.log.frequencies_hz[0])
        if np.count_nonzero(rows) < 2:
            continue
        t = times[rows]
        temps = run.column(f"t_{step.heater}_c")[rows]
        ambient = float(np.nanmedian(run.column("t_ambient_c")[rows]))
        if isinstance(step, CoolDown):
            out.append(RecordedWait(step.heater, True, step.below_c, t - t[0], temps, ambient))
            continue
        end = next((float(h["start_s"]) for h in holds if h.get("heater") == step.heater
                    and float(h.get("setpoint_c", np.nan)) == step.setpoint_c
                    and float(h["start_s"]) >= t[-1] - _SLACK_S), None)
        out.append(RecordedWait(step.heater, False, step.setpoint_c, t - t[0], temps, ambient, step.steady,
                                None if end is None else end - float(t[0])))
    return out
