"""Diagnosis: where the model fails, which effect is missing, and by how much adding it helps.

1. Fit the model (baseline plus any effects already added) and estimate the noise from the data.
2. Score every recorded variable by how much of the residual it explains (associations).
3. Fit the model plus each library effect in turn; rank by BIC, with held-out error from
   grouped cross-validation (by recording or by temperature state) for the leading candidates.
4. Verdict: 'adequate' when the residual is at the noise level and no effect earns its keep;
   otherwise 'missing_effect'. The best effect is then added and the diagnosis repeated once,
   so a second effect can be found in turn.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ecds_lab.analysis.associations import Association, residual_associations
from ecds_lab.analysis.fitting import FitResult, fit, fit_model
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import library
from ecds_lab.model.sensor_model import SensorModel

#: The residual is "at the noise level" below this multiple of the noise.
ADEQUATE_RATIO = 1.2
#: A residual above this multiple of the noise is a missing effect whatever the candidates say.
FAILING_RATIO = 1.5
#: Residual structure this many standard deviations beyond chance (for pure noise of the estimated
#: size) marks a missing effect once the residual is at least a little above the noise.
STRUCTURE_SIGNIFICANCE = 8.0
STRUCTURE_RATIO = 1.03
#: BIC improvement (negative) that counts as decisive evidence for an effect.
DECISIVE_DELTA_BIC = -20.0
#: Candidates (best by BIC) refitted from their alternative starts, and at most cross-validated.
LEADING = 3
CROSS_VALIDATED = 3
FOLDS = 4

#: Friendlier display units for parameters in explanations: name -> (unit, factor).
DISPLAY_UNITS = {"bending": ("um/K", 1e6), "bending_quadratic": ("um/K^2", 1e6), "backlash": ("um", 1e6),
                 "moist_dC": ("pF", 1e12), "moist_dG": ("uS", 1e6), "tau_tempco": ("%/K", 100.0),
                 "lag_tau": ("s", 1.0), "drying_rate": ("1/h", 3600.0), "tau_t": ("us", 1e6)}


@dataclass
class Candidate:
    """The model plus one more effect, fitted: how much better it explains the data."""

    effect: str
    fit: FitResult
    delta_bic: float
    cv_rmse_ppm: float | None = None

    @property
    def rmse_ppm(self) -> float:
        return self.fit.rms_ppm

    def effect_params(self) -> dict[str, Any]:
        own = {p.name for e in self.fit.model.effects if e.name == self.effect for p in e.parameters()}
        return {k: v for k, v in self.fit.params_table().items() if k in own}


@dataclass
class Diagnosis:
    """Everything the diagnosis found; ``to_json`` gives the JSON of docs/data-contract.md."""

    data: Measurements
    effects: list[str]
    noise: NoiseEstimate
    baseline: FitResult
    baseline_cv_rmse_ppm: float | None
    candidates: list[Candidate]
    associations: list[Association]
    verdict: str
    explanation: str
    follow_up: Diagnosis | None = None
    residual_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def noise_ppm(self) -> float:
        return self.noise.ppm

    @property
    def best(self) -> Candidate | None:
        return self.candidates[0] if self.candidates else None

    def to_json(self) -> dict[str, Any]:
        finite = self.residual_mm[np.isfinite(self.residual_mm)]
        out: dict[str, Any] = {
            "noise_ppm": round(self.noise.ppm, 3),
            "noise_method": self.noise.method,
            "baseline": {"effects": self.effects, "rmse_ppm": round(self.baseline.rms_ppm, 3),
                         "rmse_mm": round(float(np.sqrt(np.mean(finite**2))), 5) if len(finite) else None,
                         "cv_rmse_ppm": _rounded(self.baseline_cv_rmse_ppm), "bic": round(self.baseline.bic, 2),
                         "params": self.baseline.params_table()},
            "verdict": self.verdict,
            "ranking": [{"effect": c.effect, "rmse_ppm": round(c.rmse_ppm, 3), "delta_bic": round(c.delta_bic, 2),
                         "cv_rmse_ppm": _rounded(c.cv_rmse_ppm), "params": c.effect_params()}
                        for c in self.candidates],
            "associations": [{"variable": a.variable, "score": a.score, "detail": a.detail,
                              "significance": a.significance} for a in self.associations],
            "explanation": self.explanation,
        }
        if self.follow_up is not None:
            out["next"] = {k: self.follow_up.to_json()[k] for k in ("baseline", "verdict", "ranking", "explanation")}
        return out


def _rounded(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else round(value, 3)


def run_diagnosis(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None, *,
                  candidates: Sequence[str] | None = None, follow_up: bool = True,
                  cross_validate: bool = True) -> Diagnosis:
    """Diagnose ``data`` against the baseline plus ``effects``; see the module docstring.

    ``follow_up`` adds the best effect and diagnoses once more (a screening round: no alternative
    starts, no cross-validation).
    """
    effects = list(effects)
    base = fit(data, effects, sensor)
    noise = base.noise
    associations = residual_associations(data, base.residuals_ppm, noise.ppm)
    names = [n for n in (candidates or library()) if n not in effects]
    ranked = sorted((_candidate(data, effects, name, base, sensor) for name in names), key=lambda c: c.delta_bic)
    if cross_validate:  # the first round; a follow-up round only screens what is left
        ranked[:LEADING] = [c if c.rmse_ppm <= ADEQUATE_RATIO * noise.ppm else _refined(data, c, base, sensor)
                            for c in ranked[:LEADING]]
    ranked.sort(key=lambda c: c.delta_bic)
    folds = _folds(data) if cross_validate else None
    base_cv = _cv_rmse(data, effects, base, sensor, folds) if folds is not None else None
    for candidate in _competitive(ranked)[:CROSS_VALIDATED]:
        if folds is not None:
            candidate.cv_rmse_ppm = _cv_rmse(data, [*effects, candidate.effect], candidate.fit, sensor, folds)
    verdict = _verdict(base, noise, ranked, associations)
    result = Diagnosis(data, effects, noise, base, base_cv, ranked, associations, verdict, "",
                       residual_mm=_residual_mm(base, data))
    if follow_up and verdict == "missing_effect" and ranked and ranked[0].delta_bic < DECISIVE_DELTA_BIC:
        result.follow_up = run_diagnosis(data, [*effects, ranked[0].effect], sensor, candidates=candidates,
                                         follow_up=False, cross_validate=False)
    result.explanation = explain(result)
    return result


def diagnose(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None) -> dict[str, Any]:
    """The diagnosis as the JSON object of docs/data-contract.md."""
    unknown = [e for e in effects if e not in library()]
    if unknown:
        raise ValueError(f"unknown effect(s) {', '.join(unknown)}; known: {', '.join(library())}")
    return run_diagnosis(data, effects, sensor).to_json()


# -- candidates -----------------------------------------------------------------------------
def _candidate(data: Measurements, effects: list[str], name: str, base: FitResult,
               sensor: SensorConfig | None) -> Candidate:
    """Fit model + effect, starting from the current fit's values and the effect's defaults."""
    model = SensorModel(sensor, [*effects, name])
    fitted = fit_model(model, data, start=dict(base.values), multistart=False, screening=True)
    return Candidate(name, fitted, fitted.bic - base.bic)


def _refined(data: Measurements, candidate: Candidate, base: FitResult, sensor: SensorConfig | None) -> Candidate:
    """A leading candidate not yet at the noise level, refitted from its effect's alternative starts."""
    model = candidate.fit.model
    best = candidate.fit
    for alternative in model.effects[-1].alternative_starts:
        trial = fit_model(model, data, start={**base.values, **alternative}, multistart=False, screening=True)
        if trial.rms_ppm < best.rms_ppm:
            best = trial
    return Candidate(candidate.effect, best, best.bic - base.bic)


def _competitive(ranked: list[Candidate]) -> list[Candidate]:
    """Candidates whose BIC gain is at least a tenth of the best one's (the rest cannot win)."""
    if not ranked or ranked[0].delta_bic >= 0:
        return ranked[:1]
    return [c for c in ranked if c.delta_bic <= 0.1 * ranked[0].delta_bic]


def _folds(data: Measurements) -> np.ndarray | None:
    """Fold number per row: by recording when there are several, else by temperature state; None if too few."""
    if len(np.unique(data.segment)) >= FOLDS:
        groups = data.segment
    else:
        state = np.round(data.t_coil_c / 5.0) * 1000 + np.round(data.t_target_c / 5.0)
        groups = np.unique(state, return_inverse=True)[1]
        if len(np.unique(groups)) < FOLDS:
            order = np.argsort(data.time_s, kind="stable")
            groups = np.empty(len(data), int)
            groups[order] = np.arange(len(data)) * FOLDS // max(len(data), 1)
    unique = np.unique(groups)
    if len(unique) < 2 or len(data) < 8 * FOLDS:
        return None
    rng = np.random.default_rng(0)
    fold_of_group = dict(zip(unique.tolist(), rng.permutation(len(unique)) % FOLDS, strict=True))
    return np.array([fold_of_group[g] for g in groups.tolist()])


def _cv_rmse(data: Measurements, effects: list[str], full: FitResult, sensor: SensorConfig | None,
             folds: np.ndarray) -> float:
    """Held-out RMS (ppm): fit without one fold, predict it; the model still sees the whole history."""
    model = SensorModel(sensor, effects)
    squares, count = 0.0, 0
    for k in np.unique(folds):
        held = folds == k
        trained = fit_model(model, data, start=full.values, multistart=False, rows=~held, screening=True)
        r = (data.ls_h[held] / trained.predict(data)[held] - 1) * 1e6
        squares += float(r @ r)
        count += int(held.sum())
    return math.sqrt(squares / max(count, 1))


def _residual_mm(result: FitResult, data: Measurements) -> np.ndarray:
    """Residual as a position error (mm): relative residual times L over the sensitivity dL/dx."""
    predicted = result.predict(data)
    sensitivity = result.model.sensitivity(data, result.values)
    with np.errstate(all="ignore"):
        out = result.residuals_ppm * 1e-6 * predicted / sensitivity * 1e3
    return np.where(np.isfinite(data.x_m) & (np.abs(sensitivity) > 0), out, np.nan)


# -- verdict and words ----------------------------------------------------------------------
def _verdict(base: FitResult, noise: NoiseEstimate, ranked: list[Candidate], associations: list[Association]) -> str:
    """Missing effect if the residual is well above the noise; or above it and one effect decisively
    helps; or a little above it with structure in some variable far beyond chance."""
    ratio = base.rms_ppm / noise.ppm if noise.ppm > 0 else math.inf
    decisive = bool(ranked) and ranked[0].delta_bic < DECISIVE_DELTA_BIC
    structured = any(a.significance > STRUCTURE_SIGNIFICANCE for a in associations)
    if ratio > FAILING_RATIO or (decisive and ratio > ADEQUATE_RATIO) or (structured and ratio > STRUCTURE_RATIO):
        return "missing_effect"
    return "adequate"


def _value_text(name: str, entry: dict[str, Any]) -> str:
    unit, factor = DISPLAY_UNITS.get(name, (entry.get("unit", ""), 1.0))
    value = entry["value"] * factor
    stderr = entry.get("stderr")
    spread = f" +/- {stderr * factor:.2g}" if stderr is not None else ""
    return f"{name} = {value:.4g}{spread} {unit}".rstrip()


def explain(result: Diagnosis) -> str:
    """A plain-language account: where the residual lives, which effect explains it, by how much."""
    base, noise = result.baseline, result.noise.ppm
    model = "the baseline model" + (f" with {', '.join(result.effects)}" if result.effects else "")
    top = result.associations[0] if result.associations else None
    lines = []
    if result.verdict == "adequate":
        lines.append(f"{model[0].upper()}{model[1:]} explains the data to the noise level: residual "
                     f"{base.rms_ppm:.1f} ppm against {noise:.1f} ppm noise ({result.noise.method}).")
        if result.best is not None:
            lines.append(f"No effect improves it decisively (best: {result.best.effect}, "
                         f"delta BIC {result.best.delta_bic:+.1f}).")
        return " ".join(lines)
    lines.append(f"{model[0].upper()}{model[1:]} leaves {base.rms_ppm:.1f} ppm of residual, "
                 f"{base.rms_ppm / noise:.1f}x the {noise:.1f} ppm noise.")
    if top is not None:
        lines.append(f"The residual lives mostly in {top.variable} (explains {top.score:.0%}): {top.detail}.")
    best = result.best
    if best is not None and best.delta_bic < DECISIVE_DELTA_BIC:
        effect = next(e for e in best.fit.model.effects if e.name == best.effect)
        values = "; ".join(_value_text(n, v) for n, v in best.effect_params().items() if v.get("stderr") is not None)
        cv = (f", held-out {best.cv_rmse_ppm:.1f} ppm vs {result.baseline_cv_rmse_ppm:.1f} ppm"
              if best.cv_rmse_ppm is not None and result.baseline_cv_rmse_ppm is not None else "")
        lines.append(f"Adding {best.effect} ({effect.explains}) brings it from {base.rms_ppm:.1f} to "
                     f"{best.rmse_ppm:.1f} ppm (delta BIC {best.delta_bic:+.0f}{cv}); fitted {values}.")
        follow = result.follow_up
        second = follow.best if follow is not None and follow.verdict == "missing_effect" else None
        final_ppm = best.rmse_ppm
        if second is not None and second.delta_bic < DECISIVE_DELTA_BIC:
            lines.append(f"With {best.effect} added, a second effect helps: {second.effect} "
                         f"({second.fit.model.effects[-1].explains}) brings the residual to "
                         f"{second.rmse_ppm:.1f} ppm (delta BIC {second.delta_bic:+.0f}); "
                         f"fit with --effects {best.effect},{second.effect}.")
            final_ppm = second.rmse_ppm
        elif follow is not None and follow.verdict == "adequate":
            lines.append(f"With it added the model is adequate ({follow.baseline.rms_ppm:.1f} ppm).")
        if final_ppm > FAILING_RATIO * noise:
            lines.append(f"Even so the residual stays {final_ppm / noise:.1f}x the noise: the library effects "
                         "explain only part of it, and the rest lies outside the library; the associations "
                         "above show where it lives.")
    else:
        lines.append("None of the library effects explains it: the missing effect is outside the library; "
                     "look at the variables above for where it lives.")
    return " ".join(lines)


def format_diagnosis(report: dict[str, Any]) -> str:
    """Readable summary of the JSON object."""
    lines = [f"verdict: {report['verdict']}   noise {report['noise_ppm']:.1f} ppm   "
             f"baseline {report['baseline']['rmse_ppm']:.1f} ppm", "", "candidates (best first):"]
    for c in report["ranking"]:
        cv = f"  held-out {c['cv_rmse_ppm']:.1f} ppm" if c.get("cv_rmse_ppm") is not None else ""
        lines.append(f"  {c['effect']:24s} {c['rmse_ppm']:9.1f} ppm  delta BIC {c['delta_bic']:+10.1f}{cv}")
    lines += ["", "where the residual lives (strongest first):"]
    lines += [f"  {a['variable']:20s} {a['score']:.2f}  {a['detail']}" for a in report["associations"]]
    lines += ["", report["explanation"]]
    return "\n".join(lines)
