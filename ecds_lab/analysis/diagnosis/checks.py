"""The checks a claim must pass: evidence (chi-square and BIC gains), identifiable key parameters,
a physically plausible size; and when two candidates are tied."""

from __future__ import annotations

import math

import numpy as np
from scipy.special import chdtri, ndtr, ndtri  # not scipy.stats: importing it costs every diagnosis 0.3 s

from ecds_lab.analysis.diagnosis.result import DISPLAY_UNITS, Candidate
from ecds_lab.analysis.fitting import FitResult, combination_stderr
from ecds_lab.analysis.grouping import stretch_labels
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import Effect

#: BIC gain (negative) on the effect's signature readings that counts as clear evidence.
DECISIVE_DELTA_BIC = -10.0
#: ... and a fall of the residual sum of squares by this many noise variances (scaled to the campaign).
MIN_CHI2_GAIN = 25.0
#: A key parameter is identified when |value| exceeds this many standard errors ...
MIN_Z = 3.0
#: ... or, for several key parameters, when their joint Wald statistic exceeds the chi-square quantile of the same
#: two-sided tail (9 = MIN_Z^2 for one parameter): the knots of a curve may each trade with the baseline while the
#: curve as a whole is far from flat.
JOINT_TAIL = 2 * float(ndtr(-MIN_Z))  # the normal's upper tail beyond MIN_Z, twice
#: ... and lies farther than this share of its range from either bound.
BOUND_MARGIN = 1e-3
#: Two passing effects whose chi-square gains (in noise units) differ by less than this (plus a tenth
#: of the larger) are not separated.
SEPARATION_CHI2 = 10.0
#: The signature of an effect: readings whose prediction it moves by at least this share of the noise.
SIGNATURE_SHARE = 0.5


def whitened(residuals_ppm: np.ndarray, data: Measurements, noise: NoiseEstimate) -> np.ndarray:
    """Residuals weighed by each reading's noise, in ppm of the mean noise: r * noise.ppm / sigma_i."""
    if not noise.ppm > 0:
        return np.asarray(residuals_ppm, float)
    return np.asarray(residuals_ppm, float) * (noise.ppm / noise.sigma_ppm(data))


def _in_noise_units(fit: FitResult, data: Measurements, noise: NoiseEstimate) -> np.ndarray:
    """A fit's residuals weighed by each reading's noise (``whitened``), in units of the mean noise."""
    return whitened(fit.residuals_ppm, data, noise) / noise.ppm


def score_candidate(name: str, fitted: FitResult, base: FitResult, noise: NoiseEstimate, data: Measurements,
                    n_full: int) -> Candidate:
    """Evidence of a fitted candidate against the current model: BIC overall and on its signature, and
    its chi-square gain; residuals weighed by each reading's noise, gains divided by the design effect
    (correlated readings count as fewer independent ones)."""
    rc_all, rb_all = whitened(fitted.residuals_ppm, data, noise), whitened(base.residuals_ppm, data, noise)
    rss_c, rss_b = float(rc_all @ rc_all), float(rb_all @ rb_all)
    k = len(fitted.free_names) - len(base.free_names)
    penalty = max(k, 1) * math.log(max(n_full, 2))
    not_better = rss_c >= rss_b
    if not_better:  # a nested fit that did not reach the current model's solution is no evidence
        return Candidate(name, fitted, penalty, penalty, 0.0, not_better=True)
    deff = max(noise.design_effect, 1.0)
    n = len(rc_all)
    delta = n * math.log(rss_c / rss_b) / deff + penalty
    change = rc_all - rb_all  # the candidate's change of the prediction (ppm, weighed)
    signature = np.abs(change) >= SIGNATURE_SHARE * noise.ppm
    if signature.sum() < max(5, k + 2):
        signature = np.abs(change) >= np.sort(np.abs(change))[-max(5, k + 2)] if n >= 5 else np.ones(n, bool)
    rc, rb = rc_all[signature], rb_all[signature]
    n_s = int(signature.sum())
    delta_s = n_s * math.log(max(float(rc @ rc), 1e-300) / max(float(rb @ rb), 1e-300)) / deff + penalty
    scale2 = max(noise.ppm**2, rss_c / n)
    return Candidate(name, fitted, delta, delta_s, (rss_b - rss_c) / scale2 / deff)


def worst_stretch(candidate: Candidate, base: FitResult, noise: NoiseEstimate, data: Measurements
                  ) -> tuple[float, float, int]:
    """Of the stretches (``grouping.stretch_labels``) whose fit the candidate worsens by MIN_CHI2_GAIN noise
    variances or more (the gain a claim needs, the same units), the one worsened most in standard deviations of
    what noise costs a true effect there: (those deviations, its loss, its readings); (0, 0, 0) when none is.
    Were the effect true, its change of the prediction d would cost a stretch at most noise: its chi-square gain
    there is sum(d^2 + 2 d e), whose noise part has the standard deviation 2 sqrt(sum d^2) (times the design
    effect's root). A stretch far below that pays for a gain made elsewhere: the effect's size is set by structure
    it does not describe."""
    rb, rc = _in_noise_units(base, data, noise), _in_noise_units(candidate.fit, data, noise)
    labels = stretch_labels(data)
    deff = max(noise.design_effect, 1.0)
    gain = np.bincount(labels, weights=rb * rb - rc * rc)
    spread = 2.0 * np.sqrt(np.bincount(labels, weights=(rb - rc) ** 2) * deff)
    z = np.divide(gain, spread, out=np.zeros_like(gain), where=spread > 0)
    worse = np.flatnonzero(-gain / deff >= MIN_CHI2_GAIN)
    if not len(worse):
        return 0.0, 0.0, 0
    worst = int(worse[np.argmin(z[worse])])
    return float(z[worst]), float(-gain[worst] / deff), int(np.count_nonzero(labels == worst))


def check_stretches(candidate: Candidate, base: FitResult, noise: NoiseEstimate, data: Measurements) -> None:
    """Add the check ``consistent``: no stretch of readings worsened by what would count as evidence and beyond
    what noise costs a true effect there (``worst_stretch``), at the same one-sided tail as MIN_Z shared out over
    the stretches (Bonferroni)."""
    stretches = int(stretch_labels(data).max()) + 1 if len(data) else 1
    limit = float(ndtri(float(ndtr(-MIN_Z)) / stretches))
    z, loss, rows = worst_stretch(candidate, base, noise, data)
    candidate.checks["consistent"] = z >= limit
    if z < limit:
        candidate.rejected.append(f"it worsens a stretch of {rows} readings by {loss:.0f} noise variances, "
                                  f"{-z:.1f} standard deviations of what noise costs a true effect there (allowed "
                                  f"{-limit:.1f}): its gain is made elsewhere, on structure it does not describe")


def effect_action(fit: FitResult, effect: Effect, data: Measurements) -> np.ndarray:
    """What ``effect`` does in ``fit`` (ppm per reading): the prediction against the same with the effect absent (its
    size parameters zero, ``Effect.size_parameters``, or its ``absent_form``), everything else held; not finite where
    the model predicts nothing without it."""
    absent = {**fit.values, **{name: 0.0 for name in effect.size_names()}, **effect.absent_form}
    with np.errstate(all="ignore"):
        return (fit.model.predict(data, fit.values) / fit.model.predict(data, absent) - 1.0) * 1e6


def gain_where_it_acts(candidate: Candidate, base: FitResult, noise: NoiseEstimate, data: Measurements) -> float:
    """The candidate's chi-square gain (noise variances, design effect applied) on the readings its own action
    moves by SIGNATURE_SHARE of their noise: its fit against the same fit with the effect absent (its size
    parameters zero, ``Effect.size_parameters``, or its ``absent_form``), everything else held. A gain elsewhere
    is the rest of the model refitted beside it (a backlash moves no reading taken without a direction)."""
    action = effect_action(candidate.fit, candidate.effect_object, data)
    acts = np.abs(whitened(np.nan_to_num(action), data, noise)) >= SIGNATURE_SHARE * noise.ppm
    rb, rc = _in_noise_units(base, data, noise)[acts], _in_noise_units(candidate.fit, data, noise)[acts]
    return float(rb @ rb - rc @ rc) / max(noise.design_effect, 1.0)


def check_where_it_acts(candidate: Candidate, base: FitResult, noise: NoiseEstimate, data: Measurements) -> None:
    """Add the check ``acts_where_it_gains``: the evidence a claim needs (MIN_CHI2_GAIN) made on the readings the
    effect itself moves (``gain_where_it_acts``), not by what the rest of the model does beside it."""
    gain = gain_where_it_acts(candidate, base, noise, data)
    candidate.checks["acts_where_it_gains"] = gain >= MIN_CHI2_GAIN
    if gain < MIN_CHI2_GAIN:
        candidate.rejected.append(f"on the readings it moves itself it gains {gain:.1f} noise variances (needs "
                                  f"{MIN_CHI2_GAIN:g}): the rest of its gain is the model beside it refitted")


def check_candidate(candidate: Candidate) -> None:
    """Fill ``checks`` and ``rejected``: evidence, identifiability, plausible size."""
    reasons = candidate.rejected
    checks = candidate.checks
    checks["evidence"] = clear_evidence(candidate)
    if candidate.not_better:
        reasons.append("the fit with it ends no better than without it")
    elif not checks["evidence"]:
        reasons.append(f"BIC gain {candidate.delta_bic_signature:+.1f} on its signature and chi-square gain "
                       f"{candidate.chi2_gain:.1f} are not clear (needs {DECISIVE_DELTA_BIC:+g} and {MIN_CHI2_GAIN:g})")
    determined, why = identified(candidate)
    checks["identifiable"] = determined
    reasons += why
    in_range, why = plausible_size(candidate)
    checks["plausible"] = in_range
    reasons += why


#: The checks a candidate fails when a slow drift in time explains what it took as well (``check_in_time``,
#: ``check_beyond_drift``).
NEEDS_TEMPERATURE, BEYOND_DRIFT = "needs_temperature", "beyond_drift"
DRIFT_CHECKS = frozenset({NEEDS_TEMPERATURE, BEYOND_DRIFT})


def check_in_time(candidate: Candidate, in_time: FitResult, noise: NoiseEstimate, data: Measurements,
                  n_full: int) -> None:
    """Add the check ``needs_temperature`` for an effect with a course in time alone (``Effect.in_time_alone``):
    its fit must beat the same model refitted in that form (``in_time``) by the evidence a claim needs, or a slow
    drift in time, which no library effect describes, would explain what it took as well (a bridge's gain drifting
    by 126 ppm an hour was claimed as a drying at one pace from 22 C on). ``n_full`` as for ``score_candidate``."""
    _gains_clearly(candidate, NEEDS_TEMPERATURE, score_candidate(candidate.effect, candidate.fit, in_time, noise,
                                                                  data, n_full),
                   "its course needs no temperature: in time alone it fits within chi-square {gain:.1f} (needs "
                   "{needs:g}), as a slow drift would")


def check_beyond_drift(candidate: Candidate, drifting: FitResult, with_it: FitResult, noise: NoiseEstimate,
                       data: Measurements, n_full: int) -> None:
    """Add the check ``beyond_drift`` for an effect whose signature a slow drift leaves as well
    (``Effect.drift_leaves_it``): beside a straight-line drift of every reading in time (``drifting``: the current
    model with it), the effect (``with_it``: that model with the effect too) must still gain the evidence a claim
    needs. ``n_full`` as for ``score_candidate``."""
    _gains_clearly(candidate, BEYOND_DRIFT, score_candidate(candidate.effect, with_it, drifting, noise, data, n_full),
                   "beside a slow drift of every reading in time it gains chi-square {gain:.1f} (needs {needs:g}): a "
                   "drift between the sweeps leaves the same")


def clear_evidence(scored: Candidate) -> bool:
    """A fit better than the one it was scored against, by a BIC gain on its signature and a chi-square gain that
    count as clear evidence (DECISIVE_DELTA_BIC, MIN_CHI2_GAIN)."""
    return (not scored.not_better and scored.delta_bic_signature <= DECISIVE_DELTA_BIC
            and scored.chi2_gain >= MIN_CHI2_GAIN)


def _gains_clearly(candidate: Candidate, check: str, versus: Candidate, reason: str) -> None:
    """Record ``check`` on ``candidate``: its fit scored against a rival form of the model (``versus``) shows clear
    evidence; else ``reason`` (formatted with the gain and the gain needed) among its rejections."""
    clear = clear_evidence(versus)
    candidate.checks[check] = clear
    if not clear:
        candidate.rejected.append(reason.format(gain=max(versus.chi2_gain, 0.0), needs=MIN_CHI2_GAIN))


def at_bound(fit: FitResult, name: str) -> bool:
    """A parameter within BOUND_MARGIN of its range from a bound (a fit there ran into a wall, not a minimum)."""
    p = fit.parameter(name)
    span = p.upper - p.lower
    return math.isfinite(span) and min(p.value - p.lower, p.upper - p.value) <= BOUND_MARGIN * span


def identified(candidate: Candidate) -> tuple[bool, list[str]]:
    """Key parameters free, off their bounds, and clearly non-zero: one more than MIN_Z standard errors from
    zero, or the effect's size parameters (``Effect.size_parameters``, default the key ones) jointly at the same
    confidence (``joint_wald``)."""
    effect = candidate.effect_object
    keys = effect.key_names()
    held = held_at_bounds(candidate)
    reasons, best_z = [], 0.0
    for name in keys:
        p = candidate.fit.parameter(name)
        if p.fixed:
            continue
        if at_bound(candidate.fit, name):
            reasons.append(f"{name} sits at its bound ({_shown(p.value, p.unit)})")
        best_z = max(best_z, _z(candidate, name, held))
    size = tuple(n for n in effect.size_names() if not candidate.fit.parameter(n).fixed)
    if best_z < MIN_Z and not joint_wald(candidate, size, held) >= float(chdtri(max(len(size), 1), JOINT_TAIL)):
        jointly = f", {', '.join(size)} jointly as well" if len(size) > 1 else ""
        reasons.append(f"its key parameter{'s' if len(keys) > 1 else ''} {', '.join(keys)} "
                       f"{'are' if len(keys) > 1 else 'is'} not determined (|value| < {MIN_Z:g} standard errors"
                       f"{jointly})")
    spread = signature_spread(candidate)
    if spread is not None and not spread < 1.0:
        reasons.append(f"its own course is not determined (the quantity that shows it is known to a factor "
                       f"{_factor(spread)}): the data do not show {effect.name}'s signature")
    return not reasons, reasons


def joint_wald(candidate: Candidate, keys: tuple[str, ...],
               held: tuple[list[str], np.ndarray] | None = None) -> float:
    """The Wald statistic v' C^-1 v of several free key parameters (0 for fewer than two, or any of them fixed).
    Knots of a curve referred to one of its points (tau_T(x) relative to tau_T at 60 mm) trade together with the
    baseline (tau_T, C_p) along one direction, so each knot's own standard error is large while the curve's shape is
    known: the joint statistic asks whether the parameters together are away from zero. ``held``: the candidate's
    ``held_at_bounds`` when the caller has it."""
    names, full = held if held is not None else held_at_bounds(candidate)
    if len(keys) < 2 or any(name not in names for name in keys):
        return 0.0
    index = [names.index(name) for name in keys]
    covariance = full[np.ix_(index, index)]
    values = np.array([candidate.fit.values[name] for name in keys])
    if not np.all(np.isfinite(covariance)):
        return 0.0
    solved, *_ = np.linalg.lstsq(covariance, values, rcond=1e-12)
    statistic = float(values @ solved)
    return statistic if math.isfinite(statistic) and statistic >= 0 else 0.0


def signature_spread(candidate: Candidate) -> float | None:
    """Standard error of the ln of the effect's signature quantity (``Effect.signature``), judged as the one
    combination of parameters it is (``fitting.combination_stderr``: inf when the data leave it open), or None for
    an effect without one."""
    effect = candidate.effect_object
    if candidate.fit_data is None:
        return None
    shown = effect.signature(candidate.fit_data, candidate.fit.values)
    if shown is None:
        return None
    _, slopes = shown
    return combination_stderr(candidate.fit, slopes)


def _factor(spread: float) -> str:
    return f"{math.exp(spread):.3g}" if spread < 50 else "beyond e^50"


def _z(candidate: Candidate, name: str, held: tuple[list[str], np.ndarray]) -> float:
    """|value| / standard error of a free parameter (0 when fixed or without a finite standard error), the other
    parameters on their bounds held there (``held``: the candidate's ``held_at_bounds``)."""
    if candidate.fit.parameter(name).fixed:
        return 0.0
    names, covariance = held
    if name not in names:
        return 0.0
    variance = float(covariance[names.index(name), names.index(name)])
    stderr = math.sqrt(variance) if math.isfinite(variance) and variance > 0 else math.nan
    return abs(candidate.fit.values[name]) / stderr if math.isfinite(stderr) and stderr > 0 else 0.0


def held_at_bounds(candidate: Candidate) -> tuple[list[str], np.ndarray]:
    """The fit's free parameters and their covariance with every parameter on its bound other than the effect's key
    ones held there (the Schur complement): a fit that ran into a wall sits on an active constraint, not on a
    direction the data leave open. A drying of nearly free water (``bound_share`` 0.01) left the bound water's
    ``sorption_width`` and the drying order on their bounds, and their trade with the size made a drying of 17 pF
    that took 1434 ppm to 126 ppm "not determined" (z 2.0; so held, 17)."""
    fit = candidate.fit
    names = list(fit.free_names)
    keys = set(candidate.effect_object.key_names())
    held = [i for i, name in enumerate(names) if name not in keys and at_bound(fit, name)]
    covariance = fit.covariance
    if not held or not np.all(np.isfinite(covariance)):
        return names, covariance
    kept = [i for i in range(len(names)) if i not in held]
    inner, across, walls = (covariance[np.ix_(kept, kept)], covariance[np.ix_(kept, held)],
                            covariance[np.ix_(held, held)])
    solved, *_ = np.linalg.lstsq(walls, across.T, rcond=1e-12)
    return [names[i] for i in kept], inner - across @ solved


def plausible_size(candidate: Candidate) -> tuple[bool, list[str]]:
    """Every parameter with a declared physical range inside it."""
    reasons = []
    for name, (low, high) in candidate.effect_object.plausible.items():
        value = candidate.fit.values.get(name)
        if value is not None and not low <= value <= high:
            unit, factor = DISPLAY_UNITS.get(name, (candidate.fit.parameter(name).unit, 1.0))
            reasons.append(f"{name} = {_shown(value * factor, unit)} is outside the physically plausible "
                           f"{_shown(low * factor, '')}..{_shown(high * factor, unit)}")
    return not reasons, reasons


def _shown(value: float, unit: str) -> str:
    """A value in a check's reason: four significant digits and its unit, none for a pure number ('1'), so a
    ratio at its bound reads '(3)', not '(3 1)'."""
    return f"{value:.4g}" + (f" {unit}" if unit not in ("", "1") else "")


def tied(a: Candidate, b: Candidate) -> bool:
    """The data cannot prefer one of two effects: their chi-square gains differ by less than
    SEPARATION_CHI2 plus a tenth of the larger (the gains are estimates from the same noise)."""
    return abs(a.chi2_gain - b.chi2_gain) < SEPARATION_CHI2 + 0.1 * max(a.chi2_gain, b.chi2_gain)


def evidence_rank(candidate: Candidate) -> float:
    """Order of candidates, best first: the BIC gain over every reading (the signature's BIC judges whether an
    effect has evidence; which of two explains the data better is judged on all of them, as their rows differ)."""
    return candidate.delta_bic if math.isfinite(candidate.delta_bic) else math.inf
