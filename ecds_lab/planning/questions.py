"""The diagnosis's open questions, each as the effects it is about and what kind of question it is.

- ``tie``: effects that explain the data equally well (``alternatives``): which one is it?
  A claim whose round had a rival explaining the data as well (``checks.tied``: chi-square gains within the
  diagnosis's tie margin) that failed only a check the claim passed (held-out error, say) is contested: a tie too.
- ``undetermined``: clear evidence, size not determined (``undetermined``): how large is it?
- ``not_excluded``: an effect these data cannot test (``untestable``) in a part of the set-up the campaign
  exercised: present or not? An effect whose every need lies in a part the campaign never moved (the coil never
  heated, say) is not asked about (``not_asked``): the user's question was not about it.
- ``outside_library``: a residual with structure no library effect explains. No experiment can change that: an
  effect that cannot explain the residual of the readings taken does not come to explain it by more readings (an
  effect these data cannot test changes them only as the calibration already does). It is reported with where
  the residual lives, never designed for.
- ``untested``: the search stopped at its limit; re-diagnosing with the found effects given answers it, not a
  measurement.
- ``drift_alike``: a library effect would take the residual to the noise, but a slow drift of every reading in time
  between the sweeps explains it as well (``drift_alike``): that effect or a drift? Reported with the measurement
  that tells them apart (``Effect.reveal_beside_drift``), not designed for: no rival model describes the drift.
- ``calibration_form``: at one frequency, a smooth calibration curve in x takes the residual's structure
  (``calibration_form``): the calibration's form not following the sensor's coupling, or an effect the calibration
  absorbs here (asked as ``not_excluded``, where a second frequency can decide)? Reported, not designed for: no
  rival model describes a calibration's form. Like ``drift_alike``, the verdict counts such structure as explained
  otherwise, so it raises no ``outside_library`` question.
"""

from __future__ import annotations

from dataclasses import dataclass

from ecds_lab.analysis.diagnosis import Diagnosis
from ecds_lab.analysis.diagnosis.advice import HOT_K
from ecds_lab.analysis.diagnosis.advice import Design as CampaignDesign
from ecds_lab.analysis.diagnosis.checks import tied
from ecds_lab.analysis.diagnosis.verdict import outside_library as library_outside
from ecds_lab.model.effects import EffectRegistry

#: The part of the set-up each key of ``Effect.reveal_needs`` is about.
NEED_PARTS = {"coil_span_k": "coil", "hold_s": "coil", "frequencies_target_hot": "target", "target_span_k": "target",
              "directions": "slide", "finest_step_mm": "slide", "frequencies": "slide"}
#: Kinds an experiment can answer.
DESIGNABLE = ("tie", "undetermined", "not_excluded")


@dataclass(frozen=True)
class OpenQuestion:
    """One open question: its kind, the effects it is about, and the question in words."""

    kind: str
    effects: tuple[str, ...]
    text: str

    def to_json(self) -> dict[str, object]:
        return {"kind": self.kind, "effects": list(self.effects), "text": self.text}


def exercised_parts(result: Diagnosis) -> set[str]:
    """The parts of the set-up the campaign moved: the slide (any sweep), the target or the coil (heated)."""
    design = CampaignDesign.of(result.data)
    parts = set()
    if result.data.x_m.size and (~result.data.in_air).any():
        parts.add("slide")
    if design.target_span_k >= HOT_K:
        parts.add("target")
    if design.coil_span_k >= HOT_K:
        parts.add("coil")
    return parts


def asked_about(registry: EffectRegistry, effect: str, parts: set[str]) -> bool:
    """Whether the campaign asks about ``effect``: some need of its reveal lies in a part the campaign moved (an
    effect that declares no needs is always asked about)."""
    cls = registry.get(effect)
    needs = set(cls.reveal_needs) if cls is not None else set()
    return not needs or any(NEED_PARTS.get(need, "slide") in parts for need in needs)


def open_questions(result: Diagnosis, registry: EffectRegistry) -> list[OpenQuestion]:
    """Every open question of ``result``, ties first."""
    out = [OpenQuestion("tie", tuple(group), f"which of {' or '.join(group)}: they explain the data equally well")
           for group in result.alternatives]
    out += contested_claims(result)
    out += [OpenQuestion("undetermined", (name,), f"how large is {name}: clear evidence, size not determined")
            for name in result.undetermined]
    parts = exercised_parts(result)
    grouped = {name for question in out for name in question.effects}
    for name, why in result.untestable.items():
        if name in grouped or not asked_about(registry, name, parts):
            continue
        out.append(OpenQuestion("not_excluded", (name,), f"is {name} present: these data cannot test it ({why})"))
    if result.untested:
        out.append(OpenQuestion("untested", tuple(result.untested), "the search stopped at its limit before testing "
                                f"{', '.join(result.untested)}: diagnose again with the found effects given "
                                "(--effects), no measurement needed"))
    for name in result.drift_alike:
        cls = registry.get(name)
        reveal = cls.reveal_beside_drift if cls is not None else ""
        tells = f"; to tell them apart, {reveal}" if reveal else ""
        out.append(OpenQuestion("drift_alike", (name,), f"is it {name} or a slow drift in time between the sweeps: "
                                f"each takes the residual to the noise{tells}"))
    if result.calibration_form is not None:
        absorbed = tuple(result.absorbed)
        out.append(OpenQuestion("calibration_form", absorbed, "is the residual the calibration's form (Eq. (5)) not "
                                "following this sensor's coupling, or an effect the calibration absorbs at one "
                                "frequency" + (f" ({', '.join(absorbed)})" if absorbed else "")
                                + ": a second frequency tells them apart"))
    if outside_library(result):
        where = "; ".join(f"{a.variable} ({a.detail})" for a in result.associations[:2])
        out.append(OpenQuestion("outside_library", (), f"a residual no library effect explains; it lives in {where}"))
    return out


def contested_claims(result: Diagnosis) -> list[OpenQuestion]:
    """Claims with a rival of equal chi-square gain, plausible and with evidence, that failed a check the claim
    passed: the data prefer the claim on one check alone, so it is asked as a tie."""
    out = []
    for before, after in zip(result.steps, result.steps[1:], strict=False):
        if after.stands_for:
            continue
        claimed = after.effects[-1]
        best = next((c for c in before.candidates if c.effect == claimed), None)
        if best is None:
            continue
        rivals = [c.effect for c in before.candidates if c.effect != claimed and not c.passes
                  and c.checks.get("evidence") and c.checks.get("plausible", True) and tied(best, c)]
        if rivals:
            group = (claimed, *rivals)
            out.append(OpenQuestion("tie", group, f"which of {' or '.join(group)}: {claimed} is claimed, but "
                                    f"{' and '.join(rivals)} explain(s) the data as well and failed only on "
                                    + ", ".join(sorted({k for c in before.candidates if c.effect in rivals
                                                        for k in c.failed}))))
    return out


def not_asked(result: Diagnosis, registry: EffectRegistry) -> dict[str, str]:
    """Untestable effects the campaign does not ask about (name -> why), for the record."""
    parts = exercised_parts(result)
    return {name: f"the campaign never moved the part it acts in ({why})" for name, why in result.untestable.items()
            if not asked_about(registry, name, parts)}


def outside_library(result: Diagnosis) -> bool:
    """The verdict says a residual lies outside the library (docs/diagnosis.md, Verdict): not when a library effect
    takes it that a drift in time explains as well (``drift_alike``), nor when a smooth calibration curve in x takes
    it (``calibration_form``), as the verdict has it."""
    return (result.structure is not None and not result.limits_reached and not result.drift_alike
            and result.calibration_form is None
            and library_outside(result.final, result.noise, result.structure, result.associations))
