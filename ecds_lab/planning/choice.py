"""Choose the experiment that decides, and write it as a normal experiment YAML saying what it decides.

Every designable open question (``questions.DESIGNABLE``) gets its rival models (``rivals``); every candidate the
station can do (``candidates``) is scored on each question by the T-criterion (``discrimination``); a question no
candidate decides at any lab time is one this station cannot answer (``NextPlan.unanswerable``), and only candidates
within the time allowed are chosen from. A candidate's worth is the number of questions it decides (its guaranteed
Delta chi-square reaching ``DECISIVE_CHI2``, a partial share below) per hour of lab time (its plan's estimate plus
``SETUP_HOURS``); a separation beyond the decisive one counts for nothing more, since a margin is only as good as
the rival models' predictions (docs/planning.md, Scoring). The questions come in priority order (ties first: the
diagnosis's own question, then sizes, then effects not excluded); among the candidates that decide the first
question any candidate can decide, the worthiest is chosen. Where no candidate decides any question in one pass of
its sweep, those that separate are also scored passed as often as deciding needs (``_passed_more_often``). When
none decides any question within the time, the one with the largest separation is named, and said not to decide.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ecds_lab.analysis.diagnosis import Diagnosis
from ecds_lab.analysis.diagnosis.checks import MIN_Z
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.config.station import StationConfig
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.planning.candidates import CandidateExperiment, repeated, station_candidates
from ecds_lab.planning.conditions import planned_readings, room_temperature_c
from ecds_lab.planning.discrimination import (
    DECISIVE_CHI2,
    Separation,
    at_measured_size,
    at_measured_values,
    decisive,
    question_separations,
)
from ecds_lab.planning.questions import DESIGNABLE, OpenQuestion, not_asked, open_questions
from ecds_lab.planning.recorded_bridge import recorded_bridge
from ecds_lab.planning.recorded_runs import recorded_runs
from ecds_lab.planning.recorded_waits import recorded_waits
from ecds_lab.planning.rivals import Rival, nested_rivals, size_rivals, size_z, tie_rivals
from ecds_lab.planning.thermal_response import ThermalResponse

#: Lab time a run costs beyond its plan (hours): setting up, confirming, checking its file. It keeps a run of a
#: minute from outscoring one of ten that answers more.
SETUP_HOURS = 0.25
#: A candidate's sweep is passed at most this many times over to decide what one pass only separates
#: (``_passed_more_often``).
MAX_PASSES = 20
#: Pass counts tried per candidate: each the count the last one's separation asks for.
PASS_TRIALS = 3


@dataclass
class Scored:
    """A candidate with its separations per question and its worth."""

    candidate: CandidateExperiment
    separations: dict[int, list[Separation]]
    decides: float
    per_hour: float
    #: the readings the candidate will take, as scored (for a prediction at another size after the run)
    planned: Measurements | None = None

    def guaranteed(self, index: int) -> float:
        return decisive(self.separations.get(index, []))

    def to_json(self, questions: list[OpenQuestion]) -> dict[str, Any]:
        return {"name": self.candidate.name, "what": self.candidate.what, "hours": round(self.candidate.hours, 3),
                "decides": round(self.decides, 3), "per_hour": round(self.per_hour, 3),
                "questions": [{"question": questions[i].text, "predicted_delta_chi2": round(decisive(s), 1),
                               "separations": [x.to_json() for x in s]} for i, s in self.separations.items()]}


@dataclass
class NextPlan:
    """What plan-next found: the open questions, the candidates scored, the choice and why."""

    questions: list[OpenQuestion]
    rivals: dict[int, list[Rival]]
    scored: list[Scored]
    refused: dict[str, str]
    chosen: Scored | None
    why: str
    not_asked: dict[str, str] = field(default_factory=dict)
    #: questions (indices) no candidate of this station decides at any lab time: the station cannot answer them
    unanswerable: list[int] = field(default_factory=list)
    #: the campaign planned from (the diagnosis's clean readings) and its noise model
    campaign: Measurements | None = None
    noise: NoiseEstimate | None = None
    #: ties (indices) the campaign decides already, with why (``decided_by_campaign``): nothing is designed for them
    decided: dict[int, str] = field(default_factory=dict)
    #: how the planned heater waits were predicted from the campaign's recorded ones, one line per heated part it
    #: informs (``ThermalResponse.describe``; none: the station's declared figures throughout)
    heater_waits: list[str] = field(default_factory=list)
    #: the guaranteed Delta chi-square that decides each question (``needed_separation``), where not DECISIVE_CHI2
    needs: dict[int, float] = field(default_factory=dict)

    def need(self, index: int) -> float:
        """The guaranteed Delta chi-square that decides question ``index``."""
        return self.needs.get(index, DECISIVE_CHI2)

    @property
    def main_question(self) -> int | None:
        """The first question (in priority order) the choice decides, else the one it separates most."""
        if self.chosen is None or not self.chosen.separations:
            return None
        chosen = self.chosen
        return next((i for i in chosen.separations if chosen.guaranteed(i) >= self.need(i)),
                    max(chosen.separations, key=chosen.guaranteed))

    @property
    def decides(self) -> bool:
        """Whether the chosen experiment is expected to decide at least one question."""
        index = self.main_question
        return (index is not None and self.predicted_delta_chi2 is not None
                and self.predicted_delta_chi2 >= self.need(index))

    @property
    def predicted_delta_chi2(self) -> float | None:
        index = self.main_question
        return None if index is None or self.chosen is None else self.chosen.guaranteed(index)

    def predicted_at_measured_size(self, winner: str, measured: Mapping[str, float]) -> float | None:
        """The main question's predicted Delta chi-square had ``winner`` been the truth at the size the joined
        campaign measured (``discrimination.at_measured_size``, in the plan's noise model); None when the winner
        supposed no size."""
        return self._at_measured(winner, measured, at_measured_size)

    def _at_measured(self, winner: str, measured: Mapping[str, float], criterion: Callable[..., float | None],
                     **options: bool) -> float | None:
        index = self.main_question
        chosen = self.chosen
        if index is None or chosen is None or chosen.planned is None or self.campaign is None or self.noise is None:
            return None
        rivals = {r.label: r for r in self.rivals[index]}
        truth = rivals.get(winner)
        other = next((rivals[s.rival] for s in chosen.separations[index] if s.truth == winner), None)
        if truth is None or other is None:
            return None
        return criterion(truth, other, measured, self.campaign, chosen.planned, self.noise, **options)

    def predicted_at_measured_values(self, winner: str, measured: Mapping[str, float], *, at_fit: bool = False
                                     ) -> float | None:
        """The same with every value the winner supposed (its held size and the parameters the campaign cannot
        determine) at the joined campaign's (``discrimination.at_measured_values``; ``at_fit``: the winner's
        shape parameters at their fit alone, not over their plausible range)."""
        return self._at_measured(winner, measured, at_measured_values, at_fit=at_fit)

    def to_json(self) -> dict[str, Any]:
        chosen = self.chosen.to_json(self.questions) if self.chosen is not None else None
        return {"open_questions": [q.to_json() for q in self.questions],
                "rivals": {self.questions[i].text: [r.to_json() for r in rs] for i, rs in self.rivals.items()},
                "candidates": [s.to_json(self.questions) for s in self.scored],
                "refused": dict(self.refused), "not_asked": dict(self.not_asked),
                "unanswerable": [self.questions[i].text for i in self.unanswerable],
                "decided": {self.questions[i].text: why for i, why in self.decided.items()},
                "chosen": chosen, "why": self.why, "heater_waits": list(self.heater_waits),
                "needed_delta_chi2": {self.questions[i].text: round(self.need(i), 3) for i in self.rivals},
                "predicted_delta_chi2": None if self.predicted_delta_chi2 is None
                else round(self.predicted_delta_chi2, 1)}


def rivals_of(question: OpenQuestion, result: Diagnosis, registry: EffectRegistry) -> list[Rival]:
    """The fitted competing models of a designable question."""
    if question.kind == "tie":
        return tie_rivals(result, question.effects, registry)
    if question.kind == "undetermined":
        return size_rivals(result, question.effects[0], registry)
    return nested_rivals(result, question.effects[0], registry, hypothetical=True)


def needed_separation(question: OpenQuestion, result: Diagnosis, registry: EffectRegistry) -> float:
    """The guaranteed Delta chi-square that decides ``question``: DECISIVE_CHI2 between rival models; for a size
    (``size_rivals``: two sizes two standard errors apart) the one at which the joined campaign holds the size MIN_Z
    standard errors from zero, as the diagnosis needs to claim it: information I_new added to the start's 1/SE^2
    gives z^2 (1 + Delta/4), so Delta = 4 (MIN_Z^2 / z^2 - 1). A size already MIN_Z or more from zero (undetermined
    for another reason: on a bound, its course open) keeps DECISIVE_CHI2."""
    if question.kind != "undetermined":
        return DECISIVE_CHI2
    z = size_z(result, question.effects[0], registry)
    return 4.0 * (MIN_Z**2 / z**2 - 1.0) if 0.0 < z < MIN_Z else DECISIVE_CHI2


def decided_by_campaign(question: OpenQuestion, rivals: Sequence[Rival], result: Diagnosis) -> str | None:
    """Why a tie is no longer open, or None: the diagnosis's own final model, fitted to the campaign, fits it better
    than every rival model by DECISIVE_CHI2 or more. A contested claim is judged in the round it was made; a rival
    that tied there may fail once a later effect takes its share (a bending beside a conductivity change the
    search found after it), and what the campaign decides needs no experiment."""
    if question.kind != "tie":
        return None
    held = next((r for r in rivals if list(r.effects) == list(result.final.effects)), None)
    others = [r for r in rivals if r is not held]
    if held is None or not others:
        return None
    margin = min(r.chi2 - held.chi2 for r in others)
    if not margin >= DECISIVE_CHI2:
        return None
    return (f"the campaign decides it: {held.label} ({', '.join(held.effects)}) fits it better than "
            f"{' and '.join(r.label for r in others)} by {margin:.1f} noise variances (>= {DECISIVE_CHI2:g})")


def plan_next(result: Diagnosis, registry: EffectRegistry, station: StationConfig,
              max_hours: float | None = None, done: Sequence[dict[str, Any]] = (),
              runs: Sequence[str | Path] = ()) -> NextPlan:
    """Score every candidate on every designable open question and choose (module docstring). ``runs``: the
    campaign's run files, whose recorded heater waits predict the planned ones (``planning.thermal_response``;
    without them the station's declared thermal figures do) and whose bridge settings the candidates read with
    (``planning.recorded_bridge``)."""
    questions = open_questions(result, registry)
    asked = not_asked(result, registry)
    designable = [i for i, q in enumerate(questions) if q.kind in DESIGNABLE]
    if any(q.kind == "outside_library" for q in questions) and all(questions[i].kind == "not_excluded"
                                                                   for i in designable):
        designable = []  # an effect these data cannot test cannot explain their residual: the answer stands
    if not designable:
        return NextPlan(questions, {}, [], {}, None, _nothing_to_design(questions), asked)
    rivals = {i: rivals_of(questions[i], result, registry) for i in designable}
    rivals = {i: r for i, r in rivals.items() if len(r) >= 2}
    decided = {i: why for i, r in rivals.items() if (why := decided_by_campaign(questions[i], r, result)) is not None}
    rivals = {i: r for i, r in rivals.items() if i not in decided}
    if not rivals:  # e.g. an undetermined size no two sizes of which the campaign leaves as rivals
        reasons = [decided.get(i, questions[i].text) for i in designable]
        return NextPlan(questions, {}, [], {}, None, "no open question has rival models to design for: "
                        + "; ".join(reasons), asked, [], result.data, result.evidence_noise, decided)
    needs = {i: needed_separation(questions[i], result, registry) for i in rivals}
    recorded = recorded_runs(runs)
    candidates, refused = station_candidates(result.data, station, None, done, result.final.fit.model.sensor,
                                             recorded_bridge(recorded))
    room = room_temperature_c(result.data)
    response = ThermalResponse.of(recorded_waits(recorded), station.thermal)

    def score(candidate: CandidateExperiment) -> Scored | None:
        planned = planned_readings(candidate.plan, station, room, result.data, response)
        if not len(planned):
            refused[candidate.name] = "takes no readings"
            return None
        separations = {i: question_separations(questions[i].kind, rs, result.data, planned, result.evidence_noise)
                       for i, rs in rivals.items()}
        decides = sum(min(max(decisive(s), 0.0), needs[i]) / needs[i] for i, s in separations.items())
        return Scored(candidate, separations, decides, decides / (candidate.hours + SETUP_HOURS), planned)

    scored = [s for s in map(score, candidates) if s is not None]
    if not any(s.guaranteed(i) >= needs[i] for s in scored for i in rivals):
        scored += _passed_more_often(scored, needs, station, score, done)
    scored.sort(key=lambda s: (-s.per_hour, s.candidate.hours))
    unanswerable = [i for i in rivals if not any(s.guaranteed(i) >= needs[i] for s in scored)]
    over = [s for s in scored if max_hours is not None and s.candidate.hours > max_hours]
    for s in over:
        refused[s.candidate.name] = f"{s.candidate.hours:.2f} h of lab time, more than the {max_hours:g} h allowed"
    scored = [s for s in scored if s not in over]
    deciding: list[Scored] = []
    for index in rivals:  # questions in order of priority: ties first, then sizes, then effects not excluded
        deciding = [s for s in scored if s.guaranteed(index) >= needs[index]]
        if deciding:
            break
    if deciding:
        chosen: Scored | None = deciding[0]
        sized = (f", at which the joined campaign holds the size {MIN_Z:g} standard errors from zero"
                 if needs[index] != DECISIVE_CHI2 else "")
        why = (f"decides '{questions[index].text}' (T-criterion: Delta chi-square >= {needs[index]:.3g} noise "
               f"variances{sized}) and, among those that do, the most open questions per hour of lab time")
    elif len(unanswerable) == len(rivals):
        chosen, why = None, ("no open question this station can answer; no experiment plan-next can build for it "
                             "decides: "
                             + "; ".join(questions[i].text for i in unanswerable))
    elif scored:
        chosen = max(scored, key=lambda s: max((s.guaranteed(i) for i in s.separations), default=0.0))
        why = (f"no candidate within {'the time allowed' if max_hours is not None else 'reach'} reaches Delta "
               f"chi-square {DECISIVE_CHI2:g}: this one separates most, but is not expected to decide")
    else:
        chosen, why = None, "the station can do no candidate experiment within the time allowed"
    return NextPlan(questions, rivals, scored, refused, chosen, why, asked, unanswerable, result.data,
                    result.evidence_noise, decided, response.describe(), needs)


def _passed_more_often(scored: list[Scored], needs: Mapping[int, float], station: StationConfig,
                       score: Callable[[CandidateExperiment], Scored | None],
                       done: Sequence[dict[str, Any]] = ()) -> list[Scored]:
    """Where no candidate decides a question in one pass: each that separates the rivals of a question, passed as
    often as its separation, were it to grow with the passes, needs to decide that question (at most MAX_PASSES),
    scored anew. The rivals' refits share the extra readings, so the separation grows less than the readings: where
    that count falls short, again at the count its own separation asks (PASS_TRIALS counts in all). A campaign read
    with a noisier setting, or a smaller effect, needs more readings of the same experiment, not another experiment;
    the lab time then decides whether it is worth it. An experiment ``done`` in an earlier round is not offered
    again."""
    out: list[Scored] = []
    for base in scored:
        # a question more passes than MAX_PASSES would not decide even were the separation to grow with them
        short = [i for i in base.separations if needs[i] / MAX_PASSES <= base.guaranteed(i) < needs[i]]
        if not short:
            continue
        index = min(short, key=lambda i: needs[i] / base.guaranteed(i))
        passes, separation = 1, base.guaranteed(index)
        for _ in range(PASS_TRIALS):
            wanted = min(math.ceil(passes * needs[index] / separation), MAX_PASSES)
            more = repeated(base.candidate, wanted, station) if wanted > passes else None
            trial = score(more) if more is not None and more.settings() not in done else None
            if trial is None:
                break
            out.append(trial)
            passes, separation = wanted, trial.guaranteed(index)
            if not 0.0 < separation < needs[index]:
                break
    return out


def _nothing_to_design(questions: list[OpenQuestion]) -> str:
    if not questions:
        return "no open question: nothing to measure"
    outside = [q for q in questions if q.kind == "outside_library"]
    if outside:
        return ("no experiment can make a library effect explain the residual: " + outside[0].text
                + " (an effect these data cannot test changes them only as the calibration does)")
    return "; ".join(q.text for q in questions)


def header(plan: NextPlan) -> str:
    """The YAML's header comment: what the experiment decides, between which models, predicted Delta chi-square
    and lab time."""
    chosen = plan.chosen
    assert chosen is not None
    lines = [f"Planned by ecds-lab plan-next: {chosen.candidate.what}.",
             f"Lab time (the plan's estimate from the station's thermal block): {chosen.candidate.hours:.2f} h."]
    lines += [f"Heater waits predicted from the campaign's recorded ones: {line}." for line in plan.heater_waits]
    for index, separations in chosen.separations.items():
        question = plan.questions[index]
        models = " | ".join(r.label for r in plan.rivals[index])
        verdict = "decides" if decisive(separations) >= plan.need(index) else "does not decide"
        lines.append(f"{verdict}: {question.text}")
        lines.append(f"  between the models: {models}; predicted Delta chi-square "
                     f"{decisive(separations):.1f} (noise variances; >= {plan.need(index):.3g} decides)")
    lines.append(f"Why this one: {plan.why}.")
    return "".join(f"# {line}\n" for line in lines)


def experiment_yaml(plan: NextPlan) -> str:
    """The chosen experiment as YAML text, its header comment first."""
    assert plan.chosen is not None
    body = yaml.safe_dump(plan.chosen.candidate.settings(), sort_keys=False, default_flow_style=None)
    return header(plan) + body


def write_experiment(plan: NextPlan, path: Path) -> Path:
    """Write the chosen experiment's YAML to ``path``."""
    Path(path).write_text(experiment_yaml(plan), encoding="utf-8")
    return Path(path)
