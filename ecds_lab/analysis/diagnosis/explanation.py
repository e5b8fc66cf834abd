"""The diagnosis in words: the explanation, the suggested measurements and the text summary of the JSON."""

from __future__ import annotations

import math
from itertools import pairwise
from typing import Any

from ecds_lab.analysis.associations import BEYOND_CHANCE, NONE_BEYOND_CHANCE
from ecds_lab.analysis.diagnosis.result import Diagnosis, Step, figure_from_json
from ecds_lab.analysis.diagnosis.structure import ResidualStructure
from ecds_lab.analysis.diagnosis.verdict import FAILING_RATIO, STRUCTURE_SIGNIFICANCE, noise_ratio, outside_library
from ecds_lab.analysis.noise import noise_parts_text
from ecds_lab.analysis.quantities import parameter_text
from ecds_lab.model.effects import EffectRegistry


def _where(result: Diagnosis) -> str:
    strong = [a for a in result.associations if a.significance > STRUCTURE_SIGNIFICANCE][:2] or result.associations[:1]
    return "; ".join(f"{a.variable} (explains {a.score:.0%}: {a.detail})" for a in strong)


def explain(result: Diagnosis, registry: EffectRegistry | None = None) -> str:
    """A plain-language account: where the residual lives, which effects explain it, by how much, what
    the data cannot tell, and what the search left untested."""
    noise = result.noise.ppm
    first, final = result.steps[0], result.final
    model = "the baseline model" + (f" with {', '.join(result.effects)}" if result.effects else "")
    lines = []
    if result.outliers:
        lines.append(f"{len(result.outliers)} glitch reading(s) were excluded (listed under outliers).")
    lines += [f"Noise: {warning}" for warning in result.noise.warnings]
    if result.released:
        lines.append(f"The data determine {', '.join(result.released)}, which the rules would hold fixed: "
                     "fitted free.")
    ratio = noise_ratio(first, result.noise)
    if result.verdict == "adequate" and not result.claimed and len(result.steps) == 1:
        lines.append(f"{model[0].upper()}{model[1:]} explains the data to the noise level: residual "
                     f"{first.rmse_ppm:.1f} ppm against {noise:.1f} ppm noise ({result.noise.source}).")
        best = result.best
        if best is not None:
            why = "; ".join(best.rejected) or "no clear gain"
            lines.append(f"No effect earns its keep (best: {best.effect}: {why}).")
        lines += _limits_text(result)
        return " ".join(lines)
    lines.append(f"{model[0].upper()}{model[1:]} leaves {first.rmse_ppm:.1f} ppm of residual, "
                 f"{ratio:.1f}x the {noise:.1f} ppm noise ({result.noise.source}).")
    for before, step in pairwise(result.steps):
        added = step.effects[-1]
        candidate = step.added_from(before)
        effect = candidate.effect_object
        values = "; ".join(parameter_text(step.fit, p.name) for p in effect.parameters()
                           if not step.fit.parameter(p.name).fixed)
        cv = (f", held-out {candidate.cv_rmse_ppm:.1f} vs {candidate.base_cv_rmse_ppm:.1f} ppm"
              if candidate.cv_rmse_ppm is not None and candidate.base_cv_rmse_ppm is not None else "")
        figure = step.position_error(noise)
        # a campaign of the coil in air has no position to be in error: no clause, not "out of range"
        error = f", position error {figure.text('rms')}" if figure.n else ""
        if step.stands_for:
            others = [n for n in step.stands_for if n != added]
            lines.append(_sentence(f"{_beside_text(step)}the data cannot tell {' from '.join(step.stands_for)}: each "
                                   f"explains them about equally well, so none is claimed. {added} stands for the "
                                   f"group while the search goes on (from {before.rmse_ppm:.1f} to "
                                   f"{step.rmse_ppm:.1f} ppm{error}); read it as {' or '.join([added, *others])}."))
            continue
        if step.leaves_structure is not None:
            lines.append(f"Adding {added} ({effect.explains}) brings it from {before.rmse_ppm:.1f} to "
                         f"{step.rmse_ppm:.1f} ppm, but where it acts the final residual keeps structure "
                         f"{step.leaves_structure:.0f} standard deviations beyond chance: it takes only part of "
                         "something the library does not describe, so it is not claimed.")
            continue
        if step.part_of_drift is not None:
            lines.append(f"Adding {added} ({effect.explains}) brings it from {before.rmse_ppm:.1f} to "
                         f"{step.rmse_ppm:.1f} ppm, but the residual drifts in time, and beside a slow drift of "
                         f"every reading it keeps only {100 * max(step.part_of_drift, 0.0):.0f} % of that gain: it "
                         "may be a part of the drift, so it is not claimed.")
            continue
        if step.beside:
            beside = "; ".join(parameter_text(candidate.fit, p.name) for p in effect.parameters()
                               if not candidate.fit.parameter(p.name).fixed)
            form = step.beside_form or "smooth"
            lines.append(_sentence(f"{_beside_text(step)}{added} ({effect.explains}) passes every check (BIC gain "
                                   f"on its signature {candidate.delta_bic_signature:+.0f}{cv}, residual beside the "
                                   f"{form} {candidate.rmse_ppm:.1f} ppm); fitted there {beside}. It is claimed; the "
                                   f"model without the {form} leaves {step.rmse_ppm:.1f} ppm."))
            continue
        lines.append(f"Adding {added} ({effect.explains}) brings it from {before.rmse_ppm:.1f} to "
                     f"{step.rmse_ppm:.1f} ppm{error} (BIC gain on its signature "
                     f"{candidate.delta_bic_signature:+.0f}{cv}); fitted {values}.")
    if result.claimed:
        lines.append(f"Fit with --effects {','.join(result.effects + result.claimed)}"
                     + (" and one effect of each group the data cannot separate." if result.alternatives else "."))
    if result.alternatives and len(result.steps) == 1:  # undetermined effects of the first round
        for group in result.alternatives:
            lines.append(f"The data cannot tell {' from '.join(group)}: each explains them about equally well "
                         "(or neither is determined), so none is claimed.")
    if (result.alternatives or result.undetermined) and result.suggested_measurements:
        lines.append("To separate or determine them: " + "; or ".join(result.suggested_measurements) + " "
                     "(`ecds-lab plan-next` designs the experiment that decides for a given station, with its "
                     "predicted separation and lab time; docs/planning.md).")
    for name in result.undetermined:
        lines.append(f"{name} would explain part of it, but these data do not determine its size, so it is "
                     "not claimed.")
    for group in (g for g in result.partial if len(g) > 1):
        lines.append(f"{', '.join(group[:-1])} and {group[-1]} each explain part of the residual about equally, "
                     "none of them well (a flexible smooth of the residual finds much more structure than any "
                     "one takes): none is claimed.")
    lines += _limits_text(result)
    final_ratio = noise_ratio(final, result.noise)
    structure = result.structure
    outside = structure is not None and outside_library(final, result.noise, structure, result.associations)
    if result.verdict == "inconclusive" and not result.alternatives and not result.limits_reached \
            and not result.steps[0].candidates:
        untested = "; ".join(f"{k}: {v}" for k, v in result.untestable.items())
        lines.append(f"These data cannot test the library's effects ({untested}); the diagnosis is inconclusive.")
    elif outside and result.calibration_form is not None and structure is not None:
        absorbed = sorted(result.absorbed)
        lines.append(("Even so the residual stays " if len(result.steps) > 1 else "The residual stays ")
                     + f"{final_ratio:.1f}x the noise{_own_noise(structure, final_ratio)} with structure "
                     f"{_significance(result):.0f} standard deviations beyond chance, but a smooth calibration curve "
                     f"in x takes it (after it, {max(result.calibration_form.significance, 0.0):.0f} standard "
                     "deviations): at one frequency that is the calibration's form (Eq. (5)) not following this "
                     "sensor's coupling, "
                     "or an effect the calibration absorbs in these data"
                     + (f" ({', '.join(absorbed)})" if absorbed else "")
                     + f", not physics shown to be missing from the library, {_inconclusive(result)}. It "
                     "lives in " + _where(result) + ". A second frequency tells such effects from the calibration; "
                     "a coupling table for the sensor (`coupling_table:` in its YAML) gives the calibration the "
                     "coupling's true form.")
    elif outside and result.drift_alike and structure is not None:
        alike = [c for c in final.candidates if c.effect in result.drift_alike]
        taken = "; ".join(f"{c.effect} to {c.rmse_ppm:.1f} ppm ({'; '.join(c.rejected)})" for c in alike)
        lines.append(("Even so the residual stays " if len(result.steps) > 1 else "The residual stays ")
                     + f"{final_ratio:.1f}x the noise{_own_noise(structure, final_ratio)} with structure "
                     f"{_significance(result):.0f} standard deviations beyond chance. A library effect takes it to "
                     f"the noise ({taken}), but a slow drift of every reading in time explains it as well: the "
                     f"residual is {' or '.join(result.drift_alike)} or such a drift, not physics shown to be "
                     f"missing from the library, {_inconclusive(result)}. It lives in " + _where(result) + ".")
        tells = [c.effect_object.reveal_beside_drift for c in alike if c.effect_object.reveal_beside_drift]
        if tells and not (result.alternatives or result.undetermined):  # else among the measurements above
            lines.append("To tell them apart: " + "; or ".join(dict.fromkeys(tells)) + ".")
    elif outside and not result.limits_reached and structure is not None:
        rejected = [f"{c.effect} ({'; '.join(c.rejected)})" for c in final.candidates[:3] if c.rejected]
        lines.append(("Even so the residual stays " if len(result.steps) > 1 else "The residual stays ")
                     + f"{final_ratio:.1f}x the noise{_own_noise(structure, final_ratio)}; every remaining library "
                     "effect was refitted at the final model and none passes its checks"
                     + (f" ({', '.join(rejected)})" if rejected else "")
                     + ", while a flexible smooth of the residual finds structure beyond chance "
                     f"({_significance(result):.0f} standard deviations): it lies outside the library. It lives in "
                     + _where(result) + ".")
    elif outside and structure is not None:
        lines.append(f"The residual stays {final_ratio:.1f}x the noise with structure {_significance(result):.0f} "
                     "standard deviations beyond chance; whether a library effect explains it is not known, since "
                     "the search stopped first (see above). It lives in " + _where(result) + ".")
    elif final_ratio > FAILING_RATIO:
        lines.append(f"The residual is {final_ratio:.1f}x the noise estimate, but a flexible smooth finds no "
                     "structure in it beyond chance: the readings scatter more than the noise estimate says "
                     f"({result.noise.source}), {_inconclusive(result)} and claims nothing outside the "
                     "library. Scatter between moves is invisible to repeated readings of one visit: declare the "
                     "slide's repeatability, or revisit positions from the same direction so it can be measured.")
    elif result.claimed:
        lines.append(f"With {', '.join(result.claimed)} the model is adequate ({final.rmse_ppm:.1f} ppm, "
                     f"{final_ratio:.2f}x the noise).")
    return " ".join(lines)


def _inconclusive(result: Diagnosis) -> str:
    """How a residual the data cannot judge ends the text: the diagnosis is inconclusive, or, beside effects it
    claimed (verdict ``missing_effect``), what is left beyond them is."""
    if result.claimed:
        return f"so what is left beyond {', '.join(result.claimed)} is inconclusive"
    return "so the diagnosis is inconclusive"


def _own_noise(structure: ResidualStructure, pooled: float) -> str:
    """The residual against each reading's own noise (as the verdict judges it), where it differs from the pooled
    figure in the first decimal."""
    ratio = structure.noise_ratio
    return (f" ({ratio:.1f}x each reading's own noise)" if math.isfinite(ratio) and f"{ratio:.1f}" != f"{pooled:.1f}"
            else "")


def _significance(result: Diagnosis) -> float:
    """The strongest structure beyond chance: the smooth over every state or the bin means of one variable."""
    smooth = result.structure.significance if result.structure is not None else 0.0
    return max([smooth, *(a.significance for a in result.associations)])


def _limits_text(result: Diagnosis) -> list[str]:
    return [f"Note: {limit}." for limit in result.limits_reached]


def format_diagnosis(report: dict[str, Any]) -> str:
    """Readable summary of the JSON object."""
    parts = noise_parts_text(report.get("noise") or {})
    head = (f"verdict: {report['verdict']}   noise {report['noise_ppm']:.1f} ppm{f' ({parts})' if parts else ''}   "
            f"baseline {report['baseline']['rmse_ppm']:.1f} ppm")
    lines = [head]
    lines += [f"noise warning: {w}" for w in (report.get("noise_details") or {}).get("warnings", [])]
    lines += ["", "steps:"]
    for step in report.get("steps", []):
        error = (f"  position error {figure_from_json(step['position_error']).text('rms')}"
                 if step.get("position_error") and step["position_error"].get("n") else "")
        lines.append(f"  {' + '.join(['baseline'] + step['effects']):50s} {step['rmse_ppm']:9.1f} ppm{error}")
    lines += ["", "candidates against the given model (best first):"]
    for c in report["ranking"]:
        cv = f"  held-out {c['cv_rmse_ppm']:.1f} ppm" if c.get("cv_rmse_ppm") is not None else ""
        status = "passes" if c.get("passes") else "rejected: " + "; ".join(c.get("rejected_because", []))
        lines.append(f"  {c['effect']:24s} {c['rmse_ppm']:9.1f} ppm  delta BIC {c['delta_bic']:+10.1f}{cv}  {status}")
    beyond = [a for a in report["associations"] if a.get("significance", 0.0) > BEYOND_CHANCE]
    lines += ["", "where the residual lives (strongest first"
              + ("):" if beyond else f"; {NONE_BEYOND_CHANCE}):")]
    lines += [f"  {a['variable']:20s} {a['score']:.2f}  {a.get('significance', 0.0):+6.1f} sd  {a['detail']}"
              for a in report["associations"]]
    if report.get("outliers"):
        lines += ["", "excluded readings:"] + [f"  row {o['row']}: {o['reason']}" for o in report["outliers"]]
    if report.get("alternatives"):
        lines += ["", "cannot be separated: " + "; ".join(" / ".join(a) for a in report["alternatives"])]
    if report.get("partial"):
        lines += ["each explains a part, none well (not claimed): "
                  + "; ".join(" / ".join(g) for g in report["partial"])]
    if report.get("undetermined"):
        lines += ["evidence but size not determined (not claimed): " + ", ".join(report["undetermined"])]
    if report.get("drift_alike"):
        lines += ["takes the residual, but a drift in time explains it as well (not claimed): "
                  + ", ".join(report["drift_alike"])]
    if report.get("limits_reached"):
        lines += ["", "limits reached:"] + [f"  - {limit}" for limit in report["limits_reached"]]
    if report.get("untested"):
        lines += ["not tested against the final model: " + ", ".join(report["untested"])]
    if report.get("suggested_measurements"):
        lines += ["suggested measurements:"] + [f"  - {s}" for s in report["suggested_measurements"]]
    lines += ["", report["explanation"]]
    return "\n".join(lines)


def _sentence(text: str) -> str:
    """``text`` with its first letter capital."""
    return text[:1].upper() + text[1:]


def _beside_text(step: Step) -> str:
    """"beside a smooth in time_s (per frequency) that takes the residual the library does not describe, " for a step
    judged beside a nuisance (``search._beside_smooth``), else ""."""
    if not step.beside:
        return ""
    return (f"beside a {step.beside_form or 'smooth'} in {', '.join(step.beside)} (per frequency) that takes the "
            "residual the library does not describe, ")
