"""The loop: diagnose -> plan-next -> run -> add the run file to the campaign -> diagnose, until no open question
is left, nothing can be designed, or the budget of lab hours is spent.

Nothing here knows which station it drives: the run is ``ecds-lab run``'s own (``runner.session.run_experiment``),
with its Ctrl-C handling (the heaters switched off and verified, the run file closed ``aborted``); the loop then
stops at once and writes where it stood. On a real station each run is confirmed first unless ``yes``. Every
round's experiment YAML, run file and diagnosis JSON are kept in the output folder; ``investigate.json`` holds the
rounds and the final diagnosis (docs/planning.md).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ecds_lab.analysis.diagnosis import Diagnosis, run_diagnosis
from ecds_lab.config.loading import parse_yaml, read_text, validate
from ecds_lab.config.references import station_path as find_station
from ecds_lab.config.station import StationConfig
from ecds_lab.errors import RunFileError
from ecds_lab.model.effects import EffectRegistry, library
from ecds_lab.planning.choice import NextPlan, plan_next, write_experiment
from ecds_lab.planning.discrimination import expected, joined_fits, measured_fits, measured_separation
from ecds_lab.planning.questions import DESIGNABLE
from ecds_lab.runner.safe_state import signal_name
from ecds_lab.runner.session import run_experiment
from ecds_lab.storage.data_file import open_campaign

#: What each round records from its plan (``NextPlan.to_json``).
ROUND_PLAN_KEYS = ("open_questions", "unanswerable", "decided", "candidates", "chosen", "why", "predicted_delta_chi2")


@dataclass
class Investigation:
    """The rounds so far, the last diagnosis and why the loop stopped."""

    rounds: list[dict[str, Any]] = field(default_factory=list)
    final: dict[str, Any] | None = None
    stopped: str = ""
    files: list[Path] = field(default_factory=list)
    hours_spent: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return {"rounds": self.rounds, "final": self.final, "stopped": self.stopped,
                "files": [str(p) for p in self.files], "hours_spent": round(self.hours_spent, 3)}


def _diagnose(files: Sequence[Path], registry: EffectRegistry) -> tuple[Diagnosis, dict[str, Any]]:
    opened = open_campaign(files)
    result = run_diagnosis(opened.data, (), opened.sensor, registry=registry)
    return result, {"sensor": opened.sensor_summary(), **result.to_json()}


def _measured(plan: NextPlan, result: Diagnosis, registry: EffectRegistry) -> dict[str, Any] | None:
    """The chosen question's rivals refitted to the joined campaign, each with what the new diagnosis needs beyond
    the question (``discrimination.joined_fits``): their chi-squares and the measured Delta chi-square between the
    best and the next (in the new diagnosis's evidence noise, the units of the prediction); beside them the same for
    the rivals alone (the figure before, which counts a misfit both rivals share)."""
    index = plan.main_question
    if index is None:
        return None
    question = plan.questions[index].effects
    fits = joined_fits(plan.rivals[index], question, result, registry)
    winner, delta, chi2 = measured_separation(fits, result.evidence_noise)
    alone_winner, alone_delta, alone_chi2 = measured_separation(
        measured_fits(plan.rivals[index], result.data, result.evidence_noise), result.evidence_noise)
    separations = plan.chosen.separations[index] if plan.chosen else []
    at_size = plan.predicted_at_measured_size(winner, fits[winner].values)
    at_values = plan.predicted_at_measured_values(winner, fits[winner].values)
    return {"chi2": {k: round(v, 1) for k, v in chi2.items()}, "winner": winner, "delta_chi2": round(delta, 1),
            "joined_needs": [name for name in result.final.effects if name not in question],
            "predicted_if_winner": _rounded(expected(separations, winner)),
            "predicted_at_measured_size": _rounded(at_size),
            "predicted_at_measured_values": _rounded(at_values),
            "at_fit": {"predicted_if_winner": _rounded(expected(separations, winner, at_fit=True)),
                       "predicted_at_measured_values": _rounded(
                           plan.predicted_at_measured_values(winner, fits[winner].values, at_fit=True))},
            "rivals_alone": {"chi2": {k: round(v, 1) for k, v in alone_chi2.items()}, "winner": alone_winner,
                             "delta_chi2": round(alone_delta, 1)}}


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(value, 1)


def investigate(data: Sequence[Path], station: Path, output: Path, *, budget_hours: float | None = None,
                confirm: Callable[[str], bool] | None = None, registry: EffectRegistry | None = None,
                say: Callable[[str], None] = print, max_rounds: int = 10) -> Investigation:
    """Run the loop (module docstring); ``confirm`` asks before each run (None: run without asking)."""
    registry = registry if registry is not None else library()
    station_file = find_station(station)
    config = validate(str(station_file), parse_yaml(read_text(station_file), str(station_file)), StationConfig)
    if (output / "investigate.json").exists() or list(output.glob("round-*")):
        raise RunFileError(f"{output}: holds an investigation already (investigate.json or round files); "
                           "choose another -o, nothing there is replaced")
    output.mkdir(parents=True, exist_ok=True)
    state = Investigation(files=[Path(p) for p in data])
    done: list[dict[str, Any]] = []
    report: dict[str, Any] | None = None
    try:
        result, report = _diagnose(state.files, registry)
        for number in range(1, max_rounds + 1):
            remaining = None if budget_hours is None else budget_hours - state.hours_spent
            plan = plan_next(result, registry, config, remaining, done, runs=state.files)
            planned = plan.to_json()
            entry: dict[str, Any] = {"round": number, **{key: planned[key] for key in ROUND_PLAN_KEYS},
                                     "measured_delta_chi2": None, "run_file": None, "diagnosis": report}
            state.rounds.append(entry)
            _write(output, state, report)
            if plan.chosen is None or not any(q.kind in DESIGNABLE for q in plan.questions):
                state.stopped = plan.why
                break
            if not plan.decides:
                state.stopped = ("no experiment the station can do within the budget decides the open questions ("
                                 + "; ".join(q.text for q in plan.questions) + ")")
                break
            done.append(plan.chosen.candidate.settings())
            yaml_path = write_experiment(plan, output / f"round-{number}.yaml")
            what = plan.chosen.candidate.what
            say(f"round {number}: {what} ({plan.chosen.candidate.hours:.2f} h), predicted Delta chi-square "
                f"{plan.predicted_delta_chi2:.1f}; {yaml_path}")
            if confirm is not None and not confirm(f"run {yaml_path} on {station_file} ({what})?"):
                state.stopped = f"round {number}: the run was not confirmed"
                break
            run_path = output / f"round-{number}.h5"
            run = run_experiment(yaml_path, station_file, run_path, progress=False)
            state.files.append(run_path)
            # the lab time the run took on the station's clock, not the plan's estimate: a real station's heaters
            # that settle slower than its declared figures would otherwise overspend the budget unseen
            lab_hours = run.lab_s / 3600.0
            state.hours_spent += lab_hours
            entry.update(run_file=str(run_path), run_status=run.status, stopped_by=run.stopped_by,
                         lab_hours=round(lab_hours, 3), planned_hours=round(plan.chosen.candidate.hours, 3))
            if run.status != "completed":
                state.stopped = _run_ended(number, run.status, run.error, run.stopped_by, run_path, plan)
                break
            result, report = _diagnose(state.files, registry)
            measured = _measured(plan, result, registry)
            entry.update(measured=measured, measured_delta_chi2=measured["delta_chi2"] if measured else None,
                         diagnosis_after={"verdict": result.verdict, "claimed": result.claimed,
                                          "alternatives": result.alternatives})
            say(f"round {number}: measured Delta chi-square {entry['measured_delta_chi2']}; verdict {result.verdict}, "
                f"claimed {', '.join(result.claimed) or 'nothing'}")
        else:
            state.stopped = f"stopped after {max_rounds} rounds"
    except KeyboardInterrupt:
        state.stopped = "interrupted (Ctrl-C) while diagnosing or planning: no run was in progress, everything " \
                        "measured is kept"
        raise
    finally:
        _write(output, state, report)
    return state


def _run_ended(number: int, status: str, error: str, signal: int | None, path: Path, plan: NextPlan) -> str:
    """Why the loop stopped at a run that did not complete, and where it stood."""
    how = f"was stopped by {signal_name(signal)}" if signal is not None else f"ended {status}"
    open_now = "; ".join(q.text for q in plan.questions if q.kind in DESIGNABLE)
    return (f"round {number}: the run {how}, recorded {status} in {path} with everything measured (the run switched "
            f"the heaters off and checked it){f': {error}' if error else ''}; still open: {open_now}")


def _write(output: Path, state: Investigation, final: dict[str, Any] | None) -> None:
    """``investigate.json`` (rounds and final diagnosis), replaced atomically so a kill leaves the last whole one."""
    state.final = final
    path = output / "investigate.json"
    temporary = path.with_suffix(".json.part")
    temporary.write_text(json.dumps(state.to_json(), indent=1, default=_plain), encoding="utf-8")
    temporary.replace(path)


def _plain(value: object) -> object:
    if hasattr(value, "item"):
        return value.item()
    return str(value)
