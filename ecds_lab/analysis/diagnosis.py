"""Diagnosis: where the model fails, which effects are missing, and how far adding them helps.

1. Robust start: fit the model (baseline plus any effects already added), estimate the noise
   (``analysis.noise``), flag glitch readings (``analysis.outliers``), exclude them with the reason
   and refit, until no new glitch appears.
2. Forward selection: fit the model plus each effect not yet in it (library and user effects),
   starting from the current solution; a nested fit that ends worse than the current model is
   reported as such, never as evidence. An effect is claimed only when it passes every check:
   a clear BIC gain on the readings where its signature lives, a lower grouped held-out error,
   identifiable key parameters (free, not at a bound, standard error well below the value) and a
   physically plausible size. The best passing effect is added and the candidates re-ranked, while
   one passes. Effects the data cannot tell apart stop the selection: both are named as
   alternatives with the measurement that would separate them.
3. Verdict: ``adequate`` (nothing needed), ``missing_effect`` (effects named, or a residual outside
   the library, with where it lives), ``inconclusive`` (the data cannot tell).

Large campaigns are screened on a random subsample of readings; what is claimed
is refitted on all readings and must pass the evidence, identifiability and plausibility checks
there too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any

import numpy as np

from ecds_lab.analysis.associations import Association, residual_associations
from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.analysis.noise import NoiseEstimate, noise_parts_text
from ecds_lab.analysis.outliers import Outlier, describe, find_glitches
from ecds_lab.analysis.phases import phase_labels
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import Effect, library
from ecds_lab.model.sensor_model import SensorModel

#: The residual is "at the noise level" below this multiple of the noise.
ADEQUATE_RATIO = 1.2
#: A residual above this multiple of the noise is a missing effect whatever the candidates say.
FAILING_RATIO = 1.5
#: Residual structure this many standard deviations beyond chance (for pure noise of the estimated
#: size) marks a missing effect once the residual is at least a little above the noise.
STRUCTURE_SIGNIFICANCE = 8.0
STRUCTURE_RATIO = 1.03
#: BIC gain (negative) on the effect's signature readings that counts as clear evidence.
DECISIVE_DELTA_BIC = -10.0
#: ... and a fall of the residual sum of squares by this many noise variances (scaled to the campaign).
MIN_CHI2_GAIN = 25.0
#: A key parameter is identified when |value| exceeds this many standard errors ...
MIN_Z = 3.0
#: ... and lies farther than this share of its range from either bound.
BOUND_MARGIN = 1e-3
#: Alternative starts refitted with the whole model free, the best of their scouts (``_refined``).
SCOUTS_REFITTED = 2
#: Two passing effects whose chi-square gains (in noise units) differ by less than this (plus a tenth
#: of the larger) are not separated.
SEPARATION_CHI2 = 10.0
#: Once the leading candidate is at the noise, others are refitted from their alternative starts only
#: when their chi-square gain is at least this share of the leader's (they might tie with it).
TIE_REACH = 0.5
#: The signature of an effect: readings whose prediction it moves by at least this share of the noise.
SIGNATURE_SHARE = 0.5
#: Candidates (best by evidence) refitted from their alternative starts, and cross-validated.
LEADING = 3
FOLDS = 4
#: Bands of distance (or stretches of time in air) per phase that are held out together.
BLOCKS = 8
#: A block whose target or coil temperature spans more than this (K) is held out visit by visit.
VISIT_SPLIT_SPAN_K = 5.0
MAX_STEPS = 5
#: Campaigns larger than this are screened on an even subsample of this many readings.
SCREEN_ROWS = 2500
MAX_OUTLIER_ROUNDS = 3

#: Friendlier display units for parameters in explanations: name -> (unit, factor).
DISPLAY_UNITS = {"bending": ("um/K", 1e6), "bending_quadratic": ("um/K^2", 1e6), "backlash": ("um", 1e6),
                 "moist_dC": ("pF", 1e12), "moist_dG": ("uS", 1e6), "tau_tempco": ("%/K", 100.0),
                 "lag_tau": ("s", 1.0), "drying_rate": ("1/h", 3600.0), "tau_t": ("us", 1e6),
                 "former_alpha": ("ppm/K", 1e6), "screw_sin": ("um", 1e6), "screw_cos": ("um", 1e6),
                 "screw_lead": ("mm", 1e3)}


@dataclass
class Candidate:
    """The current model plus one more effect, fitted, and the checks a claim must pass."""

    effect: str
    fit: FitResult
    delta_bic: float
    delta_bic_signature: float = math.nan
    chi2_gain: float = 0.0
    cv_rmse_ppm: float | None = None
    base_cv_rmse_ppm: float | None = None
    checks: dict[str, bool] = field(default_factory=dict)
    rejected: list[str] = field(default_factory=list)
    not_better: bool = False
    fit_data: Measurements | None = None

    @property
    def rmse_ppm(self) -> float:
        return self.fit.rms_ppm

    @property
    def passes(self) -> bool:
        return bool(self.checks) and all(self.checks.values())

    @property
    def effect_object(self) -> Effect:
        return next(e for e in self.fit.model.effects if e.name == self.effect)

    def effect_params(self) -> dict[str, Any]:
        own = {p.name for p in self.effect_object.parameters()}
        return {k: v for k, v in self.fit.params_table().items() if k in own}

    def to_json(self) -> dict[str, Any]:
        return {"effect": self.effect, "rmse_ppm": round(self.rmse_ppm, 3), "delta_bic": round(self.delta_bic, 2),
                "delta_bic_signature": _rounded(self.delta_bic_signature, 2), "cv_rmse_ppm": _rounded(self.cv_rmse_ppm),
                "passes": self.passes, "checks": dict(self.checks), "rejected_because": list(self.rejected),
                "params": self.effect_params()}


@dataclass
class Step:
    """One model of the chain baseline -> +effect -> ...: its fit and figures of merit."""

    effects: list[str]
    fit: FitResult
    residual_mm: np.ndarray
    full_scale_mm: float
    candidates: list[Candidate] = field(default_factory=list)

    @property
    def rmse_ppm(self) -> float:
        return self.fit.rms_ppm

    @property
    def position_error_mm(self) -> float | None:
        finite = self.residual_mm[np.isfinite(self.residual_mm)]
        return float(np.sqrt(np.mean(finite**2))) if len(finite) else None

    @property
    def position_error_fs_pct(self) -> float | None:
        error = self.position_error_mm
        return None if error is None or not self.full_scale_mm > 0 else 100.0 * error / self.full_scale_mm

    def to_json(self) -> dict[str, Any]:
        return {"effects": list(self.effects), "rmse_ppm": round(self.rmse_ppm, 3), "bic": round(self.fit.bic, 2),
                "position_error_mm": _rounded(self.position_error_mm, 5),
                "position_error_fs_pct": _rounded(self.position_error_fs_pct, 4),
                "params": self.fit.params_table()}


@dataclass
class Diagnosis:
    """Everything the diagnosis found; ``to_json`` gives DESIGN.md's JSON object."""

    data: Measurements
    effects: list[str]
    noise: NoiseEstimate
    steps: list[Step]
    associations: list[Association]
    verdict: str
    explanation: str = ""
    outliers: list[Outlier] = field(default_factory=list)
    alternatives: list[list[str]] = field(default_factory=list)
    suggested_measurements: list[str] = field(default_factory=list)
    untestable: dict[str, str] = field(default_factory=dict)
    baseline_cv_rmse_ppm: float | None = None

    @property
    def noise_ppm(self) -> float:
        return self.noise.ppm

    @property
    def baseline(self) -> FitResult:
        return self.steps[0].fit

    @property
    def final(self) -> Step:
        return self.steps[-1]

    @property
    def claimed(self) -> list[str]:
        """Effects the diagnosis adds to the given model, in the order they were found."""
        return self.final.effects[len(self.effects):]

    @property
    def candidates(self) -> list[Candidate]:
        """The first round's ranking (candidates against the given model), best first."""
        return self.steps[0].candidates

    @property
    def best(self) -> Candidate | None:
        return self.candidates[0] if self.candidates else None

    @property
    def residual_mm(self) -> np.ndarray:
        return self.steps[0].residual_mm

    def to_json(self) -> dict[str, Any]:
        first = self.steps[0]
        return {
            "noise_ppm": round(self.noise.ppm, 3),
            "noise_method": self.noise.method,
            "noise": self.noise.to_json(),
            "baseline": {"effects": self.effects, "rmse_ppm": round(first.rmse_ppm, 3),
                         "rmse_mm": _rounded(first.position_error_mm, 5),
                         "position_error_fs_pct": _rounded(first.position_error_fs_pct, 4),
                         "cv_rmse_ppm": _rounded(self.baseline_cv_rmse_ppm), "bic": round(first.fit.bic, 2),
                         "params": first.fit.params_table()},
            "verdict": self.verdict,
            "claimed": self.claimed,
            "ranking": [c.to_json() for c in self.candidates],
            "associations": [{"variable": a.variable, "score": a.score, "detail": a.detail,
                              "significance": a.significance} for a in self.associations],
            "explanation": self.explanation,
            "outliers": [o.to_json() for o in self.outliers],
            "alternatives": [list(a) for a in self.alternatives],
            "suggested_measurements": list(self.suggested_measurements),
            "untestable": dict(self.untestable),
            "steps": [s.to_json() for s in self.steps],
        }


def _rounded(value: float | None, digits: int = 3) -> float | None:
    return None if value is None or not math.isfinite(value) else round(value, digits)


# -- entry points ---------------------------------------------------------------------------------
def run_diagnosis(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None, *,
                  candidates: Sequence[str] | None = None, max_steps: int = MAX_STEPS,
                  cross_validate: bool = True, screen_rows: int = SCREEN_ROWS) -> Diagnosis:
    """Diagnose ``data`` against the baseline plus ``effects``; see the module docstring.

    ``candidates``: the effects to try (default: every registered effect, user effects included);
    ``max_steps``: at most this many effects are added; ``cross_validate`` False skips the
    held-out check (then it cannot refuse a claim).
    """
    sensor = sensor or SensorConfig()
    effects = list(effects)
    clean, _rows, base, noise, outliers = _robust_fit(data, effects, sensor, screen_rows)
    names = [n for n in (candidates if candidates is not None else library()) if n not in effects]
    screen = _screen(clean, screen_rows)
    folds = _folds(screen) if cross_validate else None
    full_scale = float(np.ptp(clean.x_mm[np.isfinite(clean.x_m)])) if np.isfinite(clean.x_m).any() else 0.0
    steps = [Step(effects, base, _residual_mm(base, clean), full_scale)]
    alternatives: list[list[str]] = []
    untestable: dict[str, str] = {}
    base_cv = None
    claimed_cv: float | None = None
    while len(steps) <= max_steps:
        current = steps[-1]
        ranked, blocked, current_cv = _round(screen, clean, current, names, sensor, noise, folds, claimed_cv)
        if len(steps) == 1:
            untestable, base_cv = blocked, current_cv
        current.candidates = ranked
        passing = [c for c in ranked if c.passes]
        if not passing:
            if len(steps) == 1:
                undetermined = [c.effect for c in ranked if c.checks.get("evidence") and c.checks.get("plausible")
                                and not c.checks.get("identifiable")]
                if undetermined:
                    alternatives.append(undetermined)
            break
        best = passing[0]
        tied = [c for c in passing[1:] if _tied(best, c)]
        if tied:
            alternatives.append([best.effect] + [c.effect for c in tied])
            break
        refit = _full_fit(clean, best, sensor)
        if screen is not clean:  # the claim must hold on every reading, not only on the screened ones
            confirmed = _scored(best.effect, refit, current.fit, noise, 1.0, len(clean))
            _check(confirmed)
            if not confirmed.passes:
                best.checks["confirmed_on_all_readings"] = False
                best.rejected += ["on all readings: " + r for r in confirmed.rejected]
                break
        steps.append(Step([*current.effects, best.effect], refit, _residual_mm(refit, clean), full_scale))
        names = [n for n in names if n != best.effect]
        # Screened on every reading, the claimed fit is the new current model: its held-out error is known.
        claimed_cv = best.cv_rmse_ppm if refit is best.fit else None
    final = steps[-1]
    associations = residual_associations(clean, final.fit.residuals_ppm, noise.ppm)
    verdict = _verdict(steps, effects, noise, associations, alternatives, untestable)
    result = Diagnosis(clean, effects, noise, steps, associations, verdict, "", outliers, alternatives,
                       _suggestions(alternatives, steps, untestable, clean), untestable, base_cv)
    result.explanation = explain(result)
    return result


def diagnose(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None) -> dict[str, Any]:
    """The diagnosis as DESIGN.md's JSON object."""
    unknown = [e for e in effects if e not in library()]
    if unknown:
        raise ValueError(f"unknown effect(s) {', '.join(unknown)}; known: {', '.join(library())}")
    return run_diagnosis(data, effects, sensor).to_json()


# -- robust start ---------------------------------------------------------------------------------
def _robust_fit(data: Measurements, effects: list[str], sensor: SensorConfig, screen_rows: int
                ) -> tuple[Measurements, np.ndarray, FitResult, NoiseEstimate, list[Outlier]]:
    """Fit, flag glitches, exclude them and refit until none is new: the clean data and their rows."""
    model = SensorModel(sensor, effects)
    index = np.arange(len(data))
    clean = data
    if len(data) > screen_rows:  # the global search on a subsample, the polish on every reading
        screened = fit_model(model, _screen(data, screen_rows))
        fitted = fit_model(model, clean, start=screened.values, multistart=False, screening=True)
    else:
        fitted = fit_model(model, clean)
    noise = fitted.noise  # the fit's own estimate: fit and diagnose report the same noise
    outliers: list[Outlier] = []
    for _ in range(MAX_OUTLIER_ROUNDS):
        glitches = find_glitches(clean, fitted.residuals_ppm, noise.reading_ppm)
        if not glitches.any() or glitches.sum() > 0.02 * len(clean) + 2:
            break
        outliers += describe(clean, np.flatnonzero(glitches), fitted.residuals_ppm, noise.reading_ppm, index)
        keep = ~glitches
        clean, index = clean.select(keep), index[keep]
        fitted = fit_model(model, clean, start=fitted.values, multistart=False, screening=True)
        noise = fitted.noise  # the fit's own estimate: fit and diagnose report the same noise
    outliers.sort(key=lambda o: o.row)
    return clean, index, fitted, noise, outliers


# -- one round of candidates ----------------------------------------------------------------------
def _round(screen: Measurements, clean: Measurements, current: Step, names: list[str], sensor: SensorConfig,
           noise: NoiseEstimate, folds: np.ndarray | None,
           current_cv: float | None = None) -> tuple[list[Candidate], dict[str, str], float | None]:
    """Fit and check every candidate against the current model; ranked best first (passing ones
    first, then by evidence). Also: candidates these data cannot test (name -> why), and the
    current model's held-out error."""
    base = current.fit if screen is clean else _evaluate(current.fit, screen)
    weight = 1.0  # evidence as the screened readings show it: scaling it up would scale noise up as well
    ranked, untestable = [], {}
    for name in names:
        model = SensorModel(sensor, [*current.effects, name])
        effect = model.effects[-1]
        fixed = model.unidentifiable(screen)
        keys = effect.key_parameters or tuple(p.name for p in effect.parameters())
        if all(k in fixed for k in keys):
            untestable[name] = "; ".join(sorted({fixed[k] for k in keys}))
            continue
        ranked.append(_candidate(screen, model, name, base, noise, weight, len(clean)))
    ranked.sort(key=_evidence)
    # Alternative starts where another valley could change the outcome: not once the model is at the
    # noise, and not for candidates far behind the leader; once the leader is at the noise, only for
    # those close enough to tie with it (a tie is judged between each candidate's best fits).
    leader_gain = max((c.chi2_gain for c in ranked), default=0.0)
    solved = any(c.rmse_ppm <= ADEQUATE_RATIO * noise.ppm and not c.not_better for c in ranked[:1])
    if current.rmse_ppm > ADEQUATE_RATIO * noise.ppm:
        for i, candidate in enumerate(ranked[:LEADING]):
            behind = candidate.rmse_ppm > ADEQUATE_RATIO * noise.ppm
            if (candidate.not_better and not solved) or (
                    behind and candidate.chi2_gain >= (TIE_REACH if solved else 0.1) * leader_gain):
                ranked[i] = _refined(screen, candidate, base, noise, weight, len(clean))
    for candidate in ranked:
        _check(candidate)
    ranked.sort(key=lambda c: (not c.passes, _evidence(c)))
    base_cv = None
    if folds is not None and ranked and ranked[0].passes:  # the previous round's claim already has it
        base_cv = current_cv if current_cv is not None else _cv_rmse(screen, base, folds)
    leader = None
    for candidate in ranked:  # held-out error, lazily: for the leader and whatever might tie with it
        if not candidate.passes or folds is None:
            continue
        if leader is not None and not _tied(leader, candidate):
            continue
        _check_held_out(candidate, base_cv, folds, screen)
        if candidate.passes and leader is None:
            leader = candidate
    ranked.sort(key=lambda c: (not c.passes, _evidence(c)))
    return ranked, untestable, base_cv


def _tied(a: Candidate, b: Candidate) -> bool:
    """The data cannot prefer one of two effects: their chi-square gains differ by less than
    SEPARATION_CHI2 plus a tenth of the larger (the gains are estimates from the same noise)."""
    return abs(a.chi2_gain - b.chi2_gain) < SEPARATION_CHI2 + 0.1 * max(a.chi2_gain, b.chi2_gain)


def _evidence(candidate: Candidate) -> float:
    return candidate.delta_bic_signature if math.isfinite(candidate.delta_bic_signature) else math.inf


def _evaluate(result: FitResult, data: Measurements) -> FitResult:
    """A fit's solution on other rows (no refit): the screening subsample's reference."""
    residuals = (data.ls_h / result.predict(data) - 1) * 1e6
    return FitResult(result.model, result.parameters, result.stderr, result.fixed, residuals, result.covariance,
                     result.free_names, result.success, result.message, 0, 0, 0.0, result.noise)


def _candidate(data: Measurements, model: SensorModel, name: str, base: FitResult, noise: NoiseEstimate,
               weight: float, n_full: int, start: dict[str, float] | None = None) -> Candidate:
    """Fit model + effect from the current solution (and the effect's defaults or ``start``)."""
    own = {p.name for p in model.effects[-1].parameters()}
    values = {k: v for k, v in base.values.items() if k not in own}
    fitted = fit_model(model, data, start={**values, **(start or {})}, multistart=False, screening=True)
    fitted = _unreleased(fitted, base, data)
    candidate = _scored(name, fitted, base, noise, weight, n_full)
    candidate.fit_data = data
    return candidate


def _unreleased(fitted: FitResult, base: FitResult, data: Measurements) -> FitResult:
    """Baseline parameters the effect made free (``Effect.identifies``) are kept only when the data
    constrain them (standard error below half the value), otherwise fixed where the fit left them;
    secondary parameters of the effect the data leave wholly undetermined are fixed at their
    defaults; its nuisance parameters (``Effect.nuisance_parameters``) the data determine poorly are
    held where the fit left them. None then blurs the effect's key parameters."""
    released = [n for n in fitted.free_names if n not in base.free_names and n in base.values]
    loose = {n: fitted.values[n] for n in released
             if not fitted.stderr.get(n, math.inf) < 0.5 * abs(fitted.values[n])}
    effect = fitted.model.effects[-1]
    keys = effect.key_parameters or ()
    defaults = {q.name: q.value for q in effect.parameters()}
    loose.update({n: defaults[n] for n in defaults  # secondary parameters the data cannot fix at all
                  if n in fitted.free_names and n not in keys and n not in effect.nuisance_parameters
                  and not math.isfinite(fitted.stderr.get(n, math.inf))})
    loose.update({n: fitted.values[n] for n in effect.nuisance_parameters  # poorly determined shape parameters
                  if n in fitted.free_names and not fitted.stderr.get(n, math.inf) < abs(fitted.values[n])})
    if not loose:
        return fitted
    return fit_model(fitted.model, data, start=fitted.values, fixed=loose, multistart=False, screening=True)


def _scored(name: str, fitted: FitResult, base: FitResult, noise: NoiseEstimate, weight: float,
            n_full: int) -> Candidate:
    """Evidence of a fitted candidate against the current model: BIC overall and on its signature
    (scaled to the whole campaign when screening a subsample), and its chi-square gain."""
    rss_c, rss_b = float(fitted.residuals_ppm @ fitted.residuals_ppm), float(base.residuals_ppm @ base.residuals_ppm)
    k = len(fitted.free_names) - len(base.free_names)
    penalty = max(k, 1) * math.log(max(n_full, 2))
    not_better = rss_c >= rss_b
    if not_better:  # a nested fit that did not reach the current model's solution is no evidence
        return Candidate(name, fitted, penalty, penalty, 0.0, not_better=True)
    n = len(fitted.residuals_ppm)
    delta = weight * n * math.log(rss_c / rss_b) + penalty
    change = fitted.residuals_ppm - base.residuals_ppm  # the candidate's change of the prediction (ppm)
    signature = np.abs(change) >= SIGNATURE_SHARE * noise.ppm
    if signature.sum() < max(5, k + 2):
        signature = np.abs(change) >= np.sort(np.abs(change))[-max(5, k + 2)] if n >= 5 else np.ones(n, bool)
    rc, rb = fitted.residuals_ppm[signature], base.residuals_ppm[signature]
    n_s = int(signature.sum())
    delta_s = weight * n_s * math.log(max(float(rc @ rc), 1e-300) / max(float(rb @ rb), 1e-300)) + penalty
    scale2 = max(noise.ppm**2, rss_c / n)
    return Candidate(name, fitted, delta, delta_s, weight * (rss_b - rss_c) / scale2)


def _refined(data: Measurements, candidate: Candidate, base: FitResult, noise: NoiseEstimate, weight: float,
             n_full: int) -> Candidate:
    """A leading candidate not yet at the noise level, refitted from its effect's alternative starts.

    With more starts than SCOUTS_REFITTED, each is first scouted with only the effect's own parameters
    free (the current model held where it is: a few columns instead of all), and the whole model is
    refitted from the best scouts
    (a valley whose depth shows only with the model free, a plate's thickness against tau_T, say,
    need not lead the scouts)."""
    model = candidate.fit.model
    own = [p.name for p in model.effects[-1].parameters()]
    starts = [dict(alternative) for alternative in model.effects[-1].alternative_starts]
    if len(starts) > SCOUTS_REFITTED:
        held = {k: v for k, v in base.values.items() if k not in own}
        scouts = sorted((fit_model(model, data, start=start, fixed=held, multistart=False, screening=True)
                         for start in starts), key=lambda f: f.rms_ppm)
        starts = [{name: scout.values[name] for name in own} for scout in scouts[:SCOUTS_REFITTED]]
    best = candidate
    for start in starts:
        trial = _candidate(data, model, candidate.effect, base, noise, weight, n_full, start)
        if trial.fit.rms_ppm < best.fit.rms_ppm:
            best = trial
    return best


def _full_fit(clean: Measurements, candidate: Candidate, sensor: SensorConfig) -> FitResult:
    """The claimed model on every reading, from the screening solution (itself, when no subsample was screened)."""
    if clean is candidate.fit_data:
        return candidate.fit
    # From the screening solution a polish to a relative cost change of 1e-8 is all the claim needs;
    # the last digits of a slow direction are not worth thousands of evaluations on every reading.
    return fit_model(candidate.fit.model, clean, start=candidate.fit.values, multistart=False, screening=True)


# -- the checks a claim must pass -----------------------------------------------------------------
def _check(candidate: Candidate) -> None:
    """Fill ``checks`` and ``rejected``: evidence, identifiability, plausible size."""
    reasons = candidate.rejected
    checks = candidate.checks
    checks["evidence"] = ((not candidate.not_better) and candidate.delta_bic_signature <= DECISIVE_DELTA_BIC
                          and candidate.chi2_gain >= MIN_CHI2_GAIN)
    if candidate.not_better:
        reasons.append("the fit with it ends no better than without it")
    elif not checks["evidence"]:
        reasons.append(f"BIC gain {candidate.delta_bic_signature:+.1f} on its signature and chi-square gain "
                       f"{candidate.chi2_gain:.1f} are not clear (needs {DECISIVE_DELTA_BIC:+g} and {MIN_CHI2_GAIN:g})")
    identified, why = _identified(candidate)
    checks["identifiable"] = identified
    reasons += why
    plausible, why = _plausible(candidate)
    checks["plausible"] = plausible
    reasons += why


def _check_held_out(candidate: Candidate, base_cv: float | None, folds: np.ndarray, data: Measurements) -> None:
    """The grouped held-out error must fall below the current model's."""
    candidate.base_cv_rmse_ppm = base_cv
    candidate.cv_rmse_ppm = _cv_rmse(data, candidate.fit, folds)
    candidate.checks["held_out"] = base_cv is not None and candidate.cv_rmse_ppm < base_cv
    if not candidate.checks["held_out"]:
        candidate.rejected.append(f"held-out error {candidate.cv_rmse_ppm:.1f} ppm is not below the current "
                                  f"model's {base_cv:.1f} ppm")


def _identified(candidate: Candidate) -> tuple[bool, list[str]]:
    """Key parameters free, off their bounds, and at least one clearly non-zero (|value| > MIN_Z stderr)."""
    effect = candidate.effect_object
    keys = effect.key_parameters or tuple(p.name for p in effect.parameters())
    reasons, best_z = [], 0.0
    for name in keys:
        p = candidate.fit.parameter(name)
        if p.fixed:
            continue
        span = p.upper - p.lower
        if math.isfinite(span) and min(p.value - p.lower, p.upper - p.value) <= BOUND_MARGIN * span:
            reasons.append(f"{name} sits at its bound ({p.value:.4g} {p.unit})")
        stderr = candidate.fit.stderr.get(name, math.nan)
        z = abs(p.value) / stderr if math.isfinite(stderr) and stderr > 0 else 0.0
        best_z = max(best_z, z)
    if best_z < MIN_Z:
        reasons.append(f"its key parameter{'s' if len(keys) > 1 else ''} {', '.join(keys)} "
                       f"{'are' if len(keys) > 1 else 'is'} not determined (|value| < {MIN_Z:g} standard errors)")
    return not reasons, reasons


def _plausible(candidate: Candidate) -> tuple[bool, list[str]]:
    """Every parameter with a declared physical range inside it."""
    reasons = []
    for name, (low, high) in candidate.effect_object.plausible.items():
        value = candidate.fit.values.get(name)
        if value is not None and not low <= value <= high:
            unit, factor = DISPLAY_UNITS.get(name, (candidate.fit.parameter(name).unit, 1.0))
            reasons.append(f"{name} = {value * factor:.4g} {unit} is outside the physically plausible "
                           f"{low * factor:.4g}..{high * factor:.4g} {unit}")
    return not reasons, reasons


# -- subsample, folds, held-out error ---------------------------------------------------------------
def _screen(data: Measurements, limit: int) -> Measurements:
    """The data themselves, or a random subsample of ``limit`` readings (fixed seed, time order kept):
    every position, frequency and phase stays represented, which a fixed stride through sweeps of
    equal length would not guarantee."""
    if len(data) <= limit:
        return data
    rows = np.sort(np.random.default_rng(0).choice(len(data), limit, replace=False))
    return data.select(rows)


def _folds(data: Measurements) -> np.ndarray | None:
    """Fold number per row: blocks of neighbouring readings (a phase's readings in one band of distance,
    or a stretch of time for the coil in air) dealt to the folds at random; None if too few readings.

    Whole blocks are held out, so a fold is not predicted from its immediate neighbours, while every
    fold keeps each phase's temperatures (held-out error measures interpolation, not extrapolation
    of a temperature the fit never saw)."""
    if len(data) < 8 * FOLDS:
        return None
    phases = phase_labels(data)
    block = np.zeros(len(data), int)
    finite = np.isfinite(data.x_m)
    if finite.any():
        edges = np.unique(np.quantile(data.x_m[finite], np.linspace(0, 1, BLOCKS + 1)))
        block[finite] = np.clip(np.searchsorted(edges, data.x_m[finite], side="right") - 1, 0, BLOCKS - 1)
    for phase in np.unique(phases[~finite]):
        rows = np.flatnonzero((phases == phase) & ~finite)
        rows = rows[np.argsort(data.time_s[rows], kind="stable")]
        block[rows] = np.arange(len(rows)) * BLOCKS // max(len(rows), 1)
    groups = np.unique(np.column_stack([phases, block, finite]), axis=0, return_inverse=True)[1].ravel()
    groups = _split_visits(data, groups)
    unique = np.unique(groups)
    if len(unique) < 2 * FOLDS:
        return None
    rng = np.random.default_rng(0)
    fold_of_group = rng.permutation(len(unique)) % FOLDS
    return fold_of_group[groups]


def _split_visits(data: Measurements, groups: np.ndarray) -> np.ndarray:
    """Blocks whose temperatures change (a heating ramp at one distance, sweeps of one band at several
    temperatures) split into their visits (stretches of consecutive readings in time): holding out the
    whole block would hold out that temperature history, and the fit would extrapolate in temperature."""
    order = np.argsort(data.time_s, kind="stable")
    visit = np.zeros(len(data), int)
    visit[order] = np.cumsum(np.concatenate([[0], groups[order][1:] != groups[order][:-1]]))
    out = groups.copy()
    for g in np.unique(groups):
        rows = groups == g
        span = max(float(np.ptp(data.t_target_c[rows])), float(np.ptp(data.t_coil_c[rows])))
        if span > VISIT_SPLIT_SPAN_K:
            out[rows] = -1 - visit[rows]  # a block per visit (negative: apart from the whole blocks)
    return np.unique(out, return_inverse=True)[1].ravel()


def _cv_rmse(data: Measurements, full: FitResult, folds: np.ndarray) -> float:
    """Held-out RMS (ppm): fit without one fold, predict it; the model still sees the whole history."""
    squares, count = 0.0, 0
    for k in np.unique(folds):
        held = folds == k
        trained = fit_model(full.model, data, start=full.values, multistart=False, rows=~held, screening=True)
        r = (data.ls_h[held] / trained.predict(data)[held] - 1) * 1e6
        squares += float(r @ r)
        count += int(held.sum())
    return math.sqrt(squares / max(count, 1))


def _residual_mm(result: FitResult, data: Measurements) -> np.ndarray:
    """Residual as a position error (mm): relative residual times L over the sensitivity dL/dx."""
    sensitivity = result.model.relative_sensitivity(data, result.values)
    with np.errstate(all="ignore"):
        out = result.residuals_ppm * 1e-6 / sensitivity * 1e3
    return np.where(np.isfinite(data.x_m) & (np.abs(sensitivity) > 0), out, np.nan)


# -- verdict and words ----------------------------------------------------------------------------
def _structured(associations: list[Association], ratio: float) -> bool:
    return any(a.significance > STRUCTURE_SIGNIFICANCE for a in associations) and ratio > STRUCTURE_RATIO


def _verdict(steps: list[Step], effects: list[str], noise: NoiseEstimate, associations: list[Association],
             alternatives: list[list[str]], untestable: dict[str, str]) -> str:
    """missing_effect when effects were claimed or the residual is above the noise with structure;
    inconclusive when the data cannot separate the candidates or could test none of them."""
    ratio = steps[-1].rmse_ppm / noise.ppm if noise.ppm > 0 else math.inf
    failing = ratio > FAILING_RATIO or _structured(associations, ratio)
    if len(steps) > 1:
        return "missing_effect"
    if alternatives:
        return "inconclusive"
    if not failing:
        return "adequate"
    tested = steps[0].candidates
    return "missing_effect" if tested else "inconclusive"


def _suggestions(alternatives: list[list[str]], steps: list[Step], untestable: dict[str, str],
                 data: Measurements) -> list[str]:
    """Measurements that would separate the alternatives (each effect's ``reveal``), de-duplicated."""
    effects = library()
    out: list[str] = []
    for group in alternatives:
        for name in group:
            reveal = getattr(effects.get(name), "reveal", "")
            if reveal and reveal not in out:
                out.append(reveal)
    if len(np.unique(data.freq_hz)) < 2 and alternatives:
        text = "measure at 500 Hz as well: with one frequency tau_T and the coupling are tied together"
        if not any(s.startswith("measure at 500 Hz") for s in out):
            out.insert(0, text)
    return out


def _value_text(name: str, entry: dict[str, Any]) -> str:
    unit, factor = DISPLAY_UNITS.get(name, (entry.get("unit", ""), 1.0))
    value = entry["value"] * factor
    stderr = entry.get("stderr")
    spread = f" +/- {stderr * factor:.2g}" if stderr is not None else ""
    return f"{name} = {value:.4g}{spread} {unit}".rstrip()


def _where(result: Diagnosis) -> str:
    strong = [a for a in result.associations if a.significance > STRUCTURE_SIGNIFICANCE][:2] or result.associations[:1]
    return "; ".join(f"{a.variable} (explains {a.score:.0%}: {a.detail})" for a in strong)


def explain(result: Diagnosis) -> str:
    """A plain-language account: where the residual lives, which effects explain it, by how much."""
    noise = result.noise.ppm
    first, final = result.steps[0], result.final
    model = "the baseline model" + (f" with {', '.join(result.effects)}" if result.effects else "")
    lines = []
    if result.outliers:
        lines.append(f"{len(result.outliers)} glitch reading(s) were excluded (listed under outliers).")
    ratio = first.rmse_ppm / noise if noise > 0 else math.inf
    if result.verdict == "adequate":
        lines.append(f"{model[0].upper()}{model[1:]} explains the data to the noise level: residual "
                     f"{first.rmse_ppm:.1f} ppm against {noise:.1f} ppm noise ({result.noise.source}).")
        best = result.best
        if best is not None:
            why = "; ".join(best.rejected) or "no clear gain"
            lines.append(f"No effect earns its keep (best: {best.effect}: {why}).")
        return " ".join(lines)
    lines.append(f"{model[0].upper()}{model[1:]} leaves {first.rmse_ppm:.1f} ppm of residual, "
                 f"{ratio:.1f}x the {noise:.1f} ppm noise ({result.noise.source}).")
    for before, step in pairwise(result.steps):
        added = step.effects[-1]
        candidate = next(c for c in before.candidates if c.effect == added)
        effect = candidate.effect_object
        values = "; ".join(_value_text(n, v) for n, v in step.fit.params_table().items()
                           if n in {p.name for p in effect.parameters()} and v.get("stderr") is not None)
        cv = (f", held-out {candidate.cv_rmse_ppm:.1f} vs {candidate.base_cv_rmse_ppm:.1f} ppm"
              if candidate.cv_rmse_ppm is not None and candidate.base_cv_rmse_ppm is not None else "")
        error = (f", position error {step.position_error_mm:.3g} mm" if step.position_error_mm is not None else "")
        lines.append(f"Adding {added} ({effect.explains}) brings it from {before.rmse_ppm:.1f} to "
                     f"{step.rmse_ppm:.1f} ppm{error} (BIC gain on its signature "
                     f"{candidate.delta_bic_signature:+.0f}{cv}); fitted {values}.")
    if result.claimed:
        lines.append(f"Fit with --effects {','.join(result.effects + result.claimed)}.")
    for group in result.alternatives:
        if len(group) == 1:
            lines.append(f"{group[0]} would explain part of it, but these data do not determine its size, so it is "
                         "not claimed. " + " ".join(f"To see it: {s}." for s in result.suggested_measurements))
        else:
            lines.append(f"The data cannot tell {' from '.join(group)}: each explains them about equally well (or "
                         "neither is determined), so none is claimed. "
                         + " ".join(f"To separate them: {s}." for s in result.suggested_measurements))
    final_ratio = final.rmse_ppm / noise if noise > 0 else math.inf
    if result.verdict == "inconclusive" and not result.alternatives:
        untested = "; ".join(f"{k}: {v}" for k, v in result.untestable.items())
        lines.append(f"These data cannot test the library's effects ({untested}); the diagnosis is inconclusive.")
    elif final_ratio > FAILING_RATIO or _structured(result.associations, final_ratio):
        rejected = [f"{c.effect} ({'; '.join(c.rejected)})" for c in final.candidates[:3] if c.rejected]
        lines.append(("Even so the residual stays " if result.claimed else "The residual stays ")
                     + f"{final_ratio:.1f}x the noise and no further library effect passes its checks"
                     + (f" ({', '.join(rejected)})" if rejected else "")
                     + ": it lies outside the library. It lives in " + _where(result) + ".")
    elif result.claimed:
        lines.append(f"With {', '.join(result.claimed)} the model is adequate ({final.rmse_ppm:.1f} ppm, "
                     f"{final_ratio:.2f}x the noise).")
    return " ".join(lines)


def format_diagnosis(report: dict[str, Any]) -> str:
    """Readable summary of the JSON object."""
    parts = noise_parts_text(report.get("noise") or {})
    head = (f"verdict: {report['verdict']}   noise {report['noise_ppm']:.1f} ppm{f' ({parts})' if parts else ''}   "
            f"baseline {report['baseline']['rmse_ppm']:.1f} ppm")
    lines = [head, "", "steps:"]
    for step in report.get("steps", []):
        error = (f"  position error {step['position_error_mm']:.4f} mm ({step['position_error_fs_pct']:.3f} % FS)"
                 if step.get("position_error_mm") is not None and step.get("position_error_fs_pct") is not None
                 else "")
        lines.append(f"  {' + '.join(['baseline'] + step['effects']):50s} {step['rmse_ppm']:9.1f} ppm{error}")
    lines += ["", "candidates against the given model (best first):"]
    for c in report["ranking"]:
        cv = f"  held-out {c['cv_rmse_ppm']:.1f} ppm" if c.get("cv_rmse_ppm") is not None else ""
        status = "passes" if c.get("passes") else "rejected: " + "; ".join(c.get("rejected_because", []))
        lines.append(f"  {c['effect']:24s} {c['rmse_ppm']:9.1f} ppm  delta BIC {c['delta_bic']:+10.1f}{cv}  {status}")
    lines += ["", "where the residual lives (strongest first):"]
    lines += [f"  {a['variable']:20s} {a['score']:.2f}  {a['detail']}" for a in report["associations"]]
    if report.get("outliers"):
        lines += ["", "excluded readings:"] + [f"  row {o['row']}: {o['reason']}" for o in report["outliers"]]
    if report.get("alternatives"):
        lines += ["", "cannot be separated: " + "; ".join(" / ".join(a) for a in report["alternatives"])]
    if report.get("suggested_measurements"):
        lines += ["suggested measurements:"] + [f"  - {s}" for s in report["suggested_measurements"]]
    lines += ["", report["explanation"]]
    return "\n".join(lines)
