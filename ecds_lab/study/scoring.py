"""Judging one diagnosis against its case's truth, and the study's tables.

- A **confident wrong claim**: an effect claimed that no truth of the case names and that is not true of
  the faithful lab anyway (``cases.ALWAYS_TRUE``) or of the case's sensor (``cases.SENSORS``: a steel plate's
  ``magnetic_depth``).
- A **false alarm** (null cases: no truth but noise): a wrong claim, or a residual said to lie outside the
  library (verdict ``missing_effect`` with nothing claimed).
- **Right** (cases whose truth the design can reveal): every revealable library truth claimed or named
  among tied alternatives; every revealable truth outside the library reported as outside it (verdict
  ``missing_effect``, nothing false claimed); a null case not alarmed.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from ecds_lab.study.cases import ALWAYS_TRUE, SENSORS, Case, truth_kinds

#: What the verdict of a case whose effects lie outside the library must say.
OUTSIDE_WORDS = "outside the library"
#: A truth outside the library must live in one of the residual's leading associations.
LEADING_ASSOCIATIONS = 2


@dataclass
class Judgement:
    """One case's diagnosis against its truth."""

    case: Case
    verdict: str
    claimed: list[str]
    alternatives: list[list[str]]
    wrong_claims: list[str] = field(default_factory=list)
    found: list[str] = field(default_factory=list)
    missed: list[str] = field(default_factory=list)
    revealable: list[str] = field(default_factory=list)
    null: bool = False
    false_alarm: bool = False
    right: bool = False
    error: str | None = None
    #: CPU seconds the diagnosis took on its worker (the campaign's simulation not counted)
    diagnosis_cpu_s: float | None = None

    def to_json(self) -> dict[str, Any]:
        return {**self.case.to_json(), "verdict": self.verdict, "claimed": self.claimed,
                "alternatives": self.alternatives, "wrong_claims": self.wrong_claims, "found": self.found,
                "missed": self.missed, "revealable": self.revealable, "null": self.null,
                "false_alarm": self.false_alarm, "right": self.right, "error": self.error,
                "diagnosis_cpu_s": self.diagnosis_cpu_s}


def judge(case: Case, report: dict[str, Any] | None, error: str | None = None) -> Judgement:
    """Compare a ``diagnose`` JSON report with the truth of ``case``."""
    kinds = truth_kinds()
    truths = [kinds[name] for name in case.truths]
    revealable = [t for t in truths if not t.nuisance and t.revealed_by(case.design)]
    if report is None:
        return Judgement(case, "error", [], [], revealable=[t.name for t in revealable], error=error)
    claimed, alternatives = list(report["claimed"]), [list(g) for g in report["alternatives"]]
    named = set(claimed) | {name for group in alternatives for name in group}
    allowed = {name for t in truths for name in (*t.expects, *t.tied_with)}
    allowed |= {name for name, holds in ALWAYS_TRUE.items() if holds(case.design)}
    allowed |= set(SENSORS[case.sensor].always_true)
    judgement = Judgement(case, report["verdict"], claimed, alternatives,
                          wrong_claims=[name for name in claimed if name not in allowed],
                          revealable=[t.name for t in revealable])
    outside_said = report["verdict"] == "missing_effect" and OUTSIDE_WORDS in report.get("explanation", "")
    leading = [a["variable"] for a in report.get("associations", [])[:LEADING_ASSOCIATIONS]]
    for truth in revealable:
        if truth.expects:
            hit = any(name in named for name in truth.expects)
        else:  # outside the library, where it lives; or named as an effect it cannot be told from
            hit = (outside_said and (not truth.lives_in or any(v in truth.lives_in for v in leading))) \
                or any(name in named for name in truth.tied_with)
        (judgement.found if hit else judgement.missed).append(truth.name)
    judgement.null = not any(not t.nuisance for t in truths)
    alarm = bool(judgement.wrong_claims) or (report["verdict"] == "missing_effect" and not claimed)
    judgement.false_alarm = judgement.null and alarm
    if judgement.null:
        judgement.right = not judgement.false_alarm
    else:
        judgement.right = bool(revealable) and not judgement.missed and not judgement.wrong_claims
    return judgement


@dataclass(frozen=True)
class Rates:
    """The study's three figures and what they are counted over."""

    cases: int
    errors: int
    wrong_claim_cases: int
    null_cases: int
    false_alarms: int
    judged_cases: int  # null or with a revealable truth
    right_cases: int

    @property
    def wrong_claim_rate(self) -> float:
        return self.wrong_claim_cases / self.cases if self.cases else 0.0

    @property
    def false_alarm_rate(self) -> float:
        return self.false_alarms / self.null_cases if self.null_cases else 0.0

    @property
    def right_rate(self) -> float:
        return self.right_cases / self.judged_cases if self.judged_cases else 0.0

    def to_json(self) -> dict[str, Any]:
        return {"cases": self.cases, "errors": self.errors, "wrong_claim_cases": self.wrong_claim_cases,
                "wrong_claim_rate": round(self.wrong_claim_rate, 4), "null_cases": self.null_cases,
                "false_alarms": self.false_alarms, "false_alarm_rate": round(self.false_alarm_rate, 4),
                "judged_cases": self.judged_cases, "right_cases": self.right_cases,
                "right_rate": round(self.right_rate, 4)}


def rates(judgements: Sequence[Judgement]) -> Rates:
    """The study's figures over its judgements (a case that could not be diagnosed counts as wrong)."""
    judged = [j for j in judgements if j.null or j.revealable]
    return Rates(cases=len(judgements), errors=sum(j.error is not None for j in judgements),
                 wrong_claim_cases=sum(bool(j.wrong_claims) for j in judgements),
                 null_cases=sum(j.null for j in judgements), false_alarms=sum(j.false_alarm for j in judgements),
                 judged_cases=len(judged), right_cases=sum(j.right for j in judged))


def detection_table(judgements: Sequence[Judgement]) -> dict[str, dict[str, int]]:
    """Per truth: in how many cases it was revealable, and found."""
    table: dict[str, dict[str, int]] = {}
    for j in judgements:
        for name in j.revealable:
            row = table.setdefault(name, {"revealable": 0, "found": 0})
            row["revealable"] += 1
            row["found"] += name in j.found
    return dict(sorted(table.items()))


def confusion_table(judgements: Sequence[Judgement]) -> dict[str, Counter[str]]:
    """Per truth (``none`` for null cases): what the diagnosis claimed or tied, counted over its cases."""
    table: dict[str, Counter[str]] = {}
    for j in judgements:
        said = j.claimed + [" or ".join(g) for g in j.alternatives]
        if j.verdict == "missing_effect" and not j.claimed:
            said.append("outside the library")
        for truth in [t for t in j.case.truths if not truth_kinds()[t].nuisance] or ["none"]:
            table.setdefault(truth, Counter()).update(said or ["nothing"])
    return dict(sorted(table.items()))


def format_study(judgements: Sequence[Judgement], seed: int) -> str:
    """The study's report: the three rates, detection per truth, the confusion table, the wrong claims."""
    figures = rates(judgements)
    lines = [f"validation study: {figures.cases} campaigns, seed {seed}, {figures.errors} not diagnosed",
             f"confident wrong claims: {figures.wrong_claim_cases} campaigns ({100 * figures.wrong_claim_rate:.1f} %)",
             f"false alarms on null truths: {figures.false_alarms} of {figures.null_cases} "
             f"({100 * figures.false_alarm_rate:.1f} %)",
             f"right (or honestly tied): {figures.right_cases} of {figures.judged_cases} revealable or null campaigns "
             f"({100 * figures.right_rate:.1f} %)"]
    sensors = sorted({j.case.sensor for j in judgements})
    if len(sensors) > 1:
        for sensor in sensors:
            part = rates([j for j in judgements if j.case.sensor == sensor])
            lines.append(f"  on {sensor}: {part.cases} campaigns, wrong claims {part.wrong_claim_cases}, false alarms "
                         f"{part.false_alarms} of {part.null_cases}, right {part.right_cases} of {part.judged_cases}")
    lines += ["", "detection per truth (revealable by the design):"]
    for name, row in detection_table(judgements).items():
        lines.append(f"  {name:<16} {row['found']:>4} of {row['revealable']:<4}")
    lines += ["", "confusion (truth -> what was said, count):"]
    for truth, said in confusion_table(judgements).items():
        lines.append(f"  {truth:<16} " + ", ".join(f"{name} {n}" for name, n in said.most_common()))
    wrong = [j for j in judgements if j.wrong_claims]
    if wrong:
        lines += ["", "wrong claims:"]
        lines += [f"  case {j.case.number}: truth {list(j.case.truths) or 'none'}, claimed {j.wrong_claims}"
                  for j in wrong]
    return "\n".join(lines)
