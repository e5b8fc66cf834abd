"""The search: a robust start, then forward selection over the effects of a registry.

1. Robust start: fit the model (baseline plus any effects already given), estimate the noise
   (``analysis.noise``), flag glitch readings (``analysis.outliers``), exclude them with the reason and
   refit, until no new glitch appears. Baseline parameters the rules fix but the data determine
   (``identifiability.releasable``: tau_T at one frequency where the data tell it) are then freed.
2. Forward selection: fit the model plus each effect not yet in it, starting from the current solution
   (and from the starts an effect reads off the residual, e.g. a screw's lead from a periodogram); an
   effect whose signature the calibration absorbs in these data is ``untestable``. An effect is claimed
   only when it passes every check (``checks``, ``held_out``). The best passing one is added and the
   rest re-ranked against the new model. Effects the data cannot tell apart, each explaining the
   residual well, are a tie: named as ``alternatives`` with the measurements that would separate them,
   and ONE of them stands for the group in the model while the search goes on, so every separable
   effect is still found. Effects that each explain only part of the residual, none well, are no tie
   (``partial``): none is added. The search ends when no candidate passes (every remaining candidate
   refitted at the final model), or at ``max_steps`` (then said, with the effects left untested).
   A search that ends on a residual outside the library tests the remaining candidates once more beside a
   flexible nuisance that takes that residual (``nuisance``, ``_beside_smooth``): a library effect acting beside
   physics the library lacks is judged against the noise, not against that physics' residual.
3. Verdict (``verdict``): ``adequate``, ``missing_effect`` (effects claimed, or a residual the library
   does not explain and a flexible smooth finds structure in, with where it lives), ``inconclusive``.
   The search judges candidates against the noise found on the start model; the final residual is judged
   with the noise figures found about a smooth re-estimated on the final model (``noise.refreshed``), and
   every structure test leaves a margin for the noise estimate's own uncertainty (``noise_margin``).

Large campaigns are screened on a random subsample of readings; what is claimed is refitted on all
readings and must pass the evidence, identifiability and plausibility checks there too (a claim that
does not is dropped from the candidates, and the search goes on).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np

from ecds_lab import forked
from ecds_lab.analysis.associations import Association, residual_associations
from ecds_lab.analysis.blas_threads import one_blas_thread
from ecds_lab.analysis.diagnosis.advice import suggestions
from ecds_lab.analysis.diagnosis.checks import (
    BEYOND_DRIFT,
    SIGNATURE_SHARE,
    at_bound,
    check_beyond_drift,
    check_candidate,
    check_in_time,
    check_stretches,
    check_where_it_acts,
    clear_evidence,
    effect_action,
    evidence_rank,
    score_candidate,
    signature_spread,
    tied,
    whitened,
)
from ecds_lab.analysis.diagnosis.drift import gain_beside_drift
from ecds_lab.analysis.diagnosis.explanation import explain
from ecds_lab.analysis.diagnosis.held_out import SCREEN_ROWS, HeldOutFits, check_held_out, cv_rmses, folds_of
from ecds_lab.analysis.diagnosis.identifiability import (
    ReleasedModel,
    absorbed,
    beyond_calibration,
    calibration_space,
    held_nuisances,
    releasable,
    start_values,
)
from ecds_lab.analysis.diagnosis.nuisance import NAME as NUISANCE
from ecds_lab.analysis.diagnosis.nuisance import SMOOTHABLE, linear_drift_effect, smooth_effect
from ecds_lab.analysis.diagnosis.result import Candidate, Diagnosis, Step
from ecds_lab.analysis.diagnosis.structure import ResidualStructure, residual_structure
from ecds_lab.analysis.diagnosis.verdict import ADEQUATE_RATIO, STRUCTURE_SIGNIFICANCE, outside_library, verdict_of
from ecds_lab.analysis.fitting import FitResult, evaluated, fit_model, noise_of, referenced
from ecds_lab.analysis.noise import NoiseEstimate, refreshed
from ecds_lab.analysis.outliers import Outlier, describe, find_glitches
from ecds_lab.analysis.per_readings import per_readings
from ecds_lab.analysis.quantities import AT_BOUND, UNDETERMINED, parameter_status
from ecds_lab.analysis.subsample import screened
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.row_labels import row_labels
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import EffectRegistry, library
from ecds_lab.model.sensor_model import SensorModel

#: Alternative starts refitted with the whole model free, the best of their scouts (``_refined``).
SCOUTS_REFITTED = 2
#: Evaluations per free parameter (and one) a repolish's scout may take (``_tried``): it only ranks an earlier
#: effect's starts, and the best two go on with the model free from where it stopped. Scouts still going after as
#: many as a polish takes were crawling from shapes far from any valley (a drying of bound water only at 789 ppm
#: beside 129 ppm): on the faithful 10^5-reading campaign they were half of every repolish's evaluations.
REPOLISH_SCOUT_BUDGET = 4
#: Once the leading candidate is at the noise, others are refitted from their alternative starts only
#: when their chi-square gain is at least this share of the leader's (they might tie with it).
TIE_REACH = 0.5
#: Candidates (best by evidence) refitted from their alternative starts, and cross-validated.
LEADING = 3
#: At most this many effects are added (the library has eight); reaching it is reported, never silent.
MAX_STEPS = 8
MAX_OUTLIER_ROUNDS = 3
#: A round on a subsample that leaves a candidate with clear evidence but an open size is judged again on a screen
#: this many times larger, up to LARGEST_SCREEN readings (the fit's global search sample): a course that lasts an hour
#: of a week's log has a handful of a 2,500-reading subsample's readings, and thousands of the campaign's.
SCREEN_GROWTH = 8
LARGEST_SCREEN = 20_000
#: A polish of every reading on a campaign more than this many times LARGEST_SCREEN walks there first (``_polished``).
PRE_POLISH_GROWTH = 2
#: An effect leaving at least this share of its own chi-square gain as structure where it acts, with the residual
#: outside the library, explained only part of something else (``_mark_partial``).
PARTIAL_SHARE = 0.5
#: An effect acts by the slide's state alone when its action differs within each state by at most this share of its
#: size there (``_in_states_alone``).
STATE_SHARE = 0.25
#: The final residual drifts in time when time is among its first this many associations (as the study judges
#: where a residual lives); then each claim is asked what it adds beside a slow drift (``_mark_drift``).
DRIFT_ASSOCIATIONS = 2
#: The remaining candidates are judged beside a straight drift in time when it takes at least this share of what the
#: search left (``_nuisances``): the residual is then mostly a drift (seed 2033 case 41: 99.6 %; seed 2030 case 103,
#: a moist former's misfit that lives in time as well, 36 %, where a bending beside the line took a part of it).
DRIFT_SHARE = 0.5
#: ``Step.beside_form`` of an effect judged beside that straight drift (``_beside_smooth``).
STRAIGHT = "straight line"
#: The share of the final residual's structure (excess chi-square) a smooth calibration curve may leave for the residual
#: to be the calibration's form (``_calibration_takes_it``): the broad misfit of a sensor Eq. (5) does not follow is
#: taken whole (a steel plate over nine positions: 3283 -> 0; a small coil at 500 Hz: 26 -> 0), a metal object's bump
#: at 15 kHz over 16 positions only in part (a quarter to a half left: validation study seed 2026 cases 96, 103, 183).
FORM_LEAVES = 0.1
#: The nuisance a candidate is judged beside is smooth in the residual's first this many associations
#: (``_beside_smooth``). With the first two (time and the coil's temperature, which a heated campaign confounds)
#: its fits had 83 parameters, ran to their evaluation budget and took 8 s each (validation study seed 2026 case 1:
#: 4.5 -> 52 s); with the first alone the listed cases gained the same claims but one (seed 7 case 26's expansion).
SMOOTH_ASSOCIATIONS = 1
#: A tied group explains the residual well (a tie, not a set of partial explanations) when its best
#: member's chi-square gain is at least this share of the structure a flexible smooth finds beyond chance.
GOOD_SHARE = 0.6
#: Two candidates are alternatives only when at least this share of one's change of the prediction is the other's
#: (``overlap``): otherwise each explains a different part of the residual and both can be found in turn.
RIVAL_OVERLAP = 0.5


@dataclass
class _Space:
    """How the search builds its models: the sensor, the registry and the baseline parameters released."""

    sensor: SensorConfig
    registry: EffectRegistry
    released: frozenset[str] = frozenset()

    def model(self, effects: Sequence[str]) -> SensorModel:
        return ReleasedModel(self.sensor, list(effects), self.registry, self.released)

    def shared(self, data: Measurements) -> tuple[object, ...]:
        """What fits of these models to ``data`` refer to (``fitting.referenced``), for every effect there is."""
        return (data, *(self.registry[name] for name in self.registry))


def run_diagnosis(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None, *,
                  candidates: Sequence[str] | None = None, max_steps: int = MAX_STEPS,
                  cross_validate: bool = True, screen_rows: int = SCREEN_ROWS,
                  registry: EffectRegistry | None = None, fitted: FitResult | None = None) -> Diagnosis:
    """Diagnose ``data`` against the baseline plus ``effects``; see the module docstring.

    ``registry``: the effects there are (default: the library and installed packages'; the command line
    adds ``--effects-from`` files); ``candidates``: the effects to try (default: the registry's tried by
    default, ``default_candidates``); ``max_steps``: at most this many effects are added (reaching it is
    reported with what was left untested); ``cross_validate`` False skips the held-out check (then it cannot
    refuse a claim);
    ``fitted``: the baseline plus ``effects`` already fitted to ``data`` by the caller (the report's fit), where
    the robust start begins instead of fitting again.

    All of it runs on one BLAS thread (``one_blas_thread``): its least squares, projections and smooths factor tall,
    thin matrices, which BLAS threads slow down a hundredfold on a machine whose cores are busy.
    """
    with one_blas_thread():
        return _run_diagnosis(data, effects, sensor, candidates=candidates, max_steps=max_steps,
                              cross_validate=cross_validate, screen_rows=screen_rows, registry=registry, fitted=fitted)


def _run_diagnosis(data: Measurements, effects: Sequence[str], sensor: SensorConfig | None, *,
                   candidates: Sequence[str] | None, max_steps: int, cross_validate: bool, screen_rows: int,
                   registry: EffectRegistry | None, fitted: FitResult | None) -> Diagnosis:
    """``run_diagnosis``'s work."""
    registry = registry if registry is not None else library()
    unknown = [e for e in [*effects, *(candidates or ())] if e not in registry]
    if unknown:
        raise ValueError(f"unknown effect(s) {', '.join(unknown)}; known: {', '.join(registry)}")
    effects = list(effects)
    space = _Space(sensor or SensorConfig(), registry)
    clean, base, noise, outliers, released = _robust_fit(data, effects, space, screen_rows, fitted)
    space = _Space(space.sensor, registry, frozenset(released))
    names = [n for n in (candidates if candidates is not None else default_candidates(registry, space.sensor))
             if n not in effects]
    for module in sorted({m for name in names for m in registry[name].modules_for_search}):
        importlib.import_module(module)  # once here, not in every worker forked for the candidates
    screen = screened(clean, screen_rows)
    folds = folds_of(screen) if cross_validate else None
    full_scale = float(np.ptp(clean.x_mm[np.isfinite(clean.x_m)])) if np.isfinite(clean.x_m).any() else 0.0
    steps = [Step(effects, base, residual_mm(base, clean), full_scale)]
    alternatives: list[list[str]] = []
    partial: list[list[str]] = []
    undetermined: list[str] = []
    untestable: dict[str, str] = {}
    limits: list[str] = []
    untested: list[str] = []
    base_cv = None
    claimed_cv: float | None = None
    fresh = True  # a new model: its held-out error is not yet known from the round before
    work: _RoundWork | None = None
    while True:
        current = steps[-1]
        if len(steps) > max_steps:
            untested = list(names)
            if untested:
                limits.append(f"the search stopped at its limit of {max_steps} added effect(s) "
                              f"(max_steps); not tested against the final model: {', '.join(untested)}")
            break
        work = _RoundWork.kept(work, screen, current)
        ranked, blocked, current_cv = _round(screen, clean, current, names, space, noise, folds,
                                             claimed_cv if fresh else work.base_cv, work)
        if not fresh:  # the same model again, fewer names: the candidates set aside stay in its ranking
            ranked += [c for c in current.candidates if c.effect not in names]
        if len(steps) == 1:
            base_cv = current_cv if current_cv is not None else base_cv
        for name, why in blocked.items():
            untestable.setdefault(name, why)
        for candidate in ranked:  # tested against this model: what an earlier model could not test no longer holds
            untestable.pop(candidate.effect, None)
        current.candidates = ranked
        passing = [c for c in ranked if c.passes]
        if not any(c.effect in names for c in passing):  # only candidates set aside pass: judged already, nothing new
            passing = []
        grown = min(len(screen) * SCREEN_GROWTH, LARGEST_SCREEN, len(clean))
        if not passing and grown > len(screen) and _undetermined(ranked):
            # A subsample's few readings of a short course (a drying over an hour of a week's log) cannot determine
            # it; the campaign's readings may. The round is judged again on a screen SCREEN_GROWTH times larger.
            screen = screened(clean, grown)
            folds = folds_of(screen) if cross_validate else None
            claimed_cv, fresh = None, True
            continue
        if not passing:
            undetermined += [name for name in _undetermined(ranked) if name not in undetermined]
            break
        best = passing[0]
        group = [best] + [c for c in ranked if c is not best and _rival(best, c, current, noise)]
        if len(group) > 1 and not _explains_well(best, screen, current, noise):
            partial.append([c.effect for c in group])  # each explains a part, none well: no tie, none added
            names = [n for n in names if n not in {c.effect for c in group}]
            fresh = False
            continue
        earlier = len(current.effects) - len(effects)
        refit, screen_start = _full_fit_beside_starts(clean, best, earlier, screen, folds, noise.ppm)
        full = refit
        if screen is not clean:  # the claim must hold on every reading, not only on the screened ones
            confirmed = _confirmed(best.effect, refit, current.fit, noise, clean)
            if not confirmed.passes and _course_open(confirmed):
                refit = _from_own_starts(clean, refit, noise.ppm)
                confirmed = _confirmed(best.effect, refit, current.fit, noise, clean)
            if not confirmed.passes:
                best.checks["confirmed_on_all_readings"] = False
                best.rejected += ["on all readings: " + r for r in confirmed.rejected]
                names = [n for n in names if n != best.effect]
                fresh = False
                continue
        members = [c.effect for c in group] if len(group) > 1 else []
        if members:
            alternatives.append(members)
        refit = _held(_repolished(refit, clean, earlier, screen_start, noise.ppm), refit, best.effect, current.fit,
                      noise, clean)
        steps.append(Step([*current.effects, best.effect], refit, residual_mm(refit, clean), full_scale,
                          stands_for=members))
        names = [n for n in names if n not in {c.effect for c in group}]
        # Screened on every reading, the claimed fit is the new current model: its held-out error is known.
        claimed_cv = best.cv_rmse_ppm if refit is best.fit else None
        if screen_start is not None and refit is full:  # its refit on the screen, with its held-out error there
            steps[-1].on_screen = (screen, screen_start.fit)
            claimed_cv = screen_start.cv_rmse_ppm
        fresh = True
    searched = noise
    final = steps[-1]
    noise, associations, structure = _final_judgement(final, clean, searched)
    if not limits and outside_library(final, noise, structure, associations) and _beside_smooth(
            screen, clean, steps, names, space, searched, folds, associations, max_steps, alternatives):
        final = steps[-1]  # a library effect found beside the residual outside the library: judged again
        noise, associations, structure = _final_judgement(final, clean, searched)
    outside = outside_library(final, noise, structure, associations)
    if not limits and outside:
        # what each claim left is weighed against its gain, both in the noise the search measured the gain in
        acting = _where_each_acts(steps, clean, searched)
        _mark_partial(steps, clean, searched, acting, _smooth_beside(screen, associations, space), screen)
        if any(a.variable == "time_s" for a in associations[:DRIFT_ASSOCIATIONS]):
            _mark_drift(steps, clean, searched, acting)
        partial += [[step.effects[-1]] for step in steps[1:]
                    if step.leaves_structure is not None or step.part_of_drift is not None]
    if len(steps) == 1 and len(undetermined) > 1:
        alternatives.append(list(undetermined))
        undetermined = []
    taken = _calibration_takes_it(final, clean, noise, structure) if outside else None
    alike = _drift_alike(final, searched) if outside and taken is None and not limits else []
    verdict = verdict_of(steps, effects, noise, structure, alternatives, untestable, limits, associations,
                         calibration_form=taken is not None, drift_alike=bool(alike))
    result = Diagnosis(clean, effects, noise, steps, associations, verdict, "", outliers, alternatives, [],
                       untestable, base_cv, limits, untested, partial, undetermined,
                       {name: "the data determine it (see docs/diagnosis.md)" for name in released}, structure,
                       searched, taken, alike)
    result.suggested_measurements = suggestions(result, registry)
    result.explanation = explain(result, registry)
    return result


def diagnose(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None, *,
             registry: EffectRegistry | None = None, also_try: Sequence[str] = ()) -> dict[str, Any]:
    """The diagnosis as DESIGN.md's JSON object; ``also_try``: effects not tried by default to try as well
    (``diagnose --try``, e.g. plate_recession)."""
    candidates = None
    if also_try:
        defaults = default_candidates(registry if registry is not None else library(), sensor)
        candidates = [*defaults, *(n for n in also_try if n not in defaults)]
    return run_diagnosis(data, effects, sensor, registry=registry, candidates=candidates).to_json()


def _final_judgement(final: Step, clean: Measurements, searched: NoiseEstimate
                     ) -> tuple[NoiseEstimate, list[Association], ResidualStructure]:
    """The final model's noise, the associations of its residual and the residual's structure. The search judged
    every candidate against the noise found on the start model (``searched``); the final model's residual is
    judged, and its noise reported, with the figures found about a smooth taken from the final model itself.
    Where the residual lives: each reading weighed by its noise, correlated readings counted as fewer."""
    noise = refreshed(searched, _judging_noise(final.fit, clean), clean)
    return noise, _associations(clean, final.fit.residuals_ppm, noise), residual_structure(
        clean, final.fit.residuals_ppm, noise)


def _associations(clean: Measurements, residuals_ppm: np.ndarray, noise: NoiseEstimate) -> list[Association]:
    return residual_associations(clean, whitened(residuals_ppm, clean, noise),
                                 noise.ppm * math.sqrt(max(noise.design_effect, 1.0)), noise.variance_shares(clean))


def _calibration_takes_it(final: Step, clean: Measurements, noise: NoiseEstimate, structure: ResidualStructure
                          ) -> ResidualStructure | None:
    """At one frequency, the structure of the final residual (``structure``) once a smooth calibration curve in x
    took what it can (``identifiability.beyond_calibration``), where that leaves nothing outside the library and no
    more than FORM_LEAVES of the structure: the calibration's form (Eq. (5)) not following this sensor's coupling, or an
    effect the calibration absorbs in these data (the same curve made it ``untestable``), not physics shown to be
    missing from the library. None otherwise."""
    left = beyond_calibration(final.fit.model, clean, final.fit.values, final.fit.residuals_ppm, noise)
    if left is None:
        return None
    beside = residual_structure(clean, left, noise)
    if beside.excess_chi2 > FORM_LEAVES * structure.excess_chi2:
        return None  # the curve follows part of it only: a bump narrower than the calibration bends
    return None if outside_library(final, noise, beside, _associations(clean, left, noise)) else beside


def _judging_noise(fit: FitResult, clean: Measurements) -> NoiseEstimate:
    """The noise the final residual is judged with, found on that residual: about a smooth, leaving out what every
    sweep over the same positions shares (``noise.estimate_noise``'s ``beside_sweeps``). A bump in x a few positions
    wide (the coil passing a bracket) is in every sweep; a smooth cannot follow it, so it counted as noise and hid
    itself (validation study seed 2030 case 186: x 7.0 standard deviations beyond chance, 10.9 with the bump left
    out of the noise). The search keeps the start model's noise, about a smooth alone: with the profile taken out,
    the baseline's misfit at close range stood 45-170 sigmas from a sweep's turning points and the glitch rule
    excluded five real readings."""
    return noise_of(fit, clean, beside_sweeps=True)


def _beside_smooth(screen: Measurements, clean: Measurements, steps: list[Step], names: list[str], space: _Space,
                   noise: NoiseEstimate, folds: np.ndarray | None, associations: Sequence[Association],
                   max_steps: int, alternatives: list[list[str]]) -> bool:
    """With the search ended on a residual outside the library, the remaining candidates judged again beside a
    flexible nuisance that takes that residual (``nuisance.smooth_effect``: splines in the variables of its first
    SMOOTH_ASSOCIATIONS associations beyond chance), fitted with the final model; and, where time is among the
    residual's leading associations, beside the simplest drift in time, a straight line per frequency
    (``nuisance.linear_drift_effect``), which cannot follow a state's window as a smooth in time does (a bending
    while the target is hot, its signature 99 % a smooth in time's: validation study seed 2033 case 41). A
    candidate passing every check against that nuisance model (evidence, identifiability, plausibility, held out;
    no stretch of readings worsened beyond what noise costs a true effect, ``checks.check_stretches``; its evidence
    made on the readings it moves itself, ``checks.check_where_it_acts``) is claimed beside the residual outside the
    library: refitted without the nuisance and appended to ``steps`` (``Step.beside``), then the rest are judged
    again. Candidates that tie there are a group the data cannot separate (appended to ``alternatives``), the best
    standing for it as in the search. Beside the straight line only such a group is reported, no single effect
    claimed: a line leaves the drift's slow wander, and a claim resting on it took a part of the drift (seed 2026 case
    9: a bending fitted to the wander while the target was hot; seed 2032 case 101: a lead screw of 18 mm lead,
    its size undetermined without the line, to a metal object's bump); a tie claims nothing and asks the
    question. True when any was added. ``names`` loses the effects added. Not on a screened
    campaign (a subsample): a claim there would need confirming on every reading beside the nuisance, which this
    does not do yet."""
    if screen is not clean:
        return False
    full_scale = steps[-1].full_scale_mm
    added = False
    for beside, variables, form in _nuisances(screen, steps[-1], space, noise, associations):
        while names and len(steps) <= max_steps:
            final = steps[-1]
            model = beside.model([*final.effects, NUISANCE])
            base = fit_model(model, screen, start=final.fit.values, multistart=False, screening=True)
            current = Step([*final.effects, NUISANCE], base, residual_mm(base, screen), full_scale)
            ranked, _, _ = _round(screen, screen, current, names, beside, noise, folds)
            for candidate in ranked:
                if candidate.passes:  # a gain made on structure the nuisance leaves, at a cost elsewhere, is no claim
                    check_stretches(candidate, base, noise, screen)
                    check_where_it_acts(candidate, base, noise, screen)
            passing = [c for c in ranked if c.passes]
            if not passing:
                break
            best = passing[0]
            group = [best] + [c for c in ranked if c is not best and _rival(best, c, current, noise)]
            members = [c.effect for c in group] if len(group) > 1 else []
            if form == STRAIGHT and not members:
                break  # a claim must not rest on what a line leaves of a drift (its wander): beside it, ties only
            # from the final model without the nuisance and the effect's own values beside it (the baseline's values
            # beside the nuisance hold what the nuisance took from them)
            own = {p.name: best.fit.values[p.name] for p in best.effect_object.parameters()}
            refit = fit_model(space.model([*final.effects, best.effect]), clean, start={**final.fit.values, **own},
                              multistart=False, screening=True)
            final.candidates = [best, *(c for c in final.candidates if c.effect != best.effect)]
            steps.append(Step([*final.effects, best.effect], refit, residual_mm(refit, clean), full_scale,
                              stands_for=members, beside=list(variables), beside_form=form))
            if members:
                alternatives.append(members)
            for member in {c.effect for c in group}:
                names.remove(member)
            added = True
    return added


def _nuisances(screen: Measurements, final: Step, space: _Space, noise: NoiseEstimate,
               associations: Sequence[Association]) -> list[tuple[_Space, list[str], str]]:
    """The nuisances ``_beside_smooth`` judges the remaining candidates beside, in turn, as (space, variables,
    form): the flexible smooth (``_smooth_beside``), then, where time is among the residual's first
    DRIFT_ASSOCIATIONS associations, a straight line in time per frequency (``nuisance.linear_drift_effect``) if it
    takes at least DRIFT_SHARE of what the final model leaves (weighed by the noise): the residual is then mostly a
    drift, which a line describes without following any state's window."""
    out = []
    smooth = _smooth_beside(screen, associations, space)
    if smooth is not None:
        out.append((smooth, _smoothed_variables(associations), "smooth"))
    drift = linear_drift_effect(screen) if any(a.variable == "time_s" for a in associations[:DRIFT_ASSOCIATIONS]
                                               ) else None
    if drift is None:
        return out
    drifting = _Space(space.sensor, space.registry.with_effects(drift), space.released)
    with_drift = fit_model(drifting.model([*final.effects, NUISANCE]), screen, start=final.fit.values,
                           multistart=False, screening=True)
    before = whitened(_residuals_on(final, screen), screen, noise)
    after = whitened(with_drift.residuals_ppm, screen, noise)
    left = float(before @ before)
    if left > 0 and 1.0 - float(after @ after) / left >= DRIFT_SHARE:
        out.append((drifting, ["time_s"], STRAIGHT))
    return out


def _where_each_acts(steps: list[Step], data: Measurements, noise: NoiseEstimate) -> list[np.ndarray]:
    """Per step after the first, the readings where its effect acts: those whose prediction it moved by
    SIGNATURE_SHARE of their noise."""
    threshold = SIGNATURE_SHARE * noise.sigma_ppm(data)
    predictions = [step.fit.predict(data) for step in steps]
    return [np.abs((prediction / previous - 1) * 1e6) >= threshold for previous, prediction in pairwise(predictions)]


def _mark_partial(steps: list[Step], data: Measurements, noise: NoiseEstimate, acting: list[np.ndarray],
                  beside: _Space | None, judged_on: Measurements) -> None:
    """With a residual outside the library left at the end, an effect claimed on the way that leaves structure
    beyond chance where it acts (the readings whose prediction it moved by SIGNATURE_SHARE of the noise), at
    least PARTIAL_SHARE of what it took (its chi-square gain, counted over ``data``'s readings: ``_gain_on``),
    only took a part of what the library does not describe (a bending a part of a drift in time): it is not claimed
    (``Step.leaves_structure``). An effect that took nearly all of what lives where it acts (moisture drying written
    another way) stays claimed.
    Structure the same states show where the effect does not act is not the effect's to leave
    (``beyond_idle_states``): a metal object's bump in x, cold and hot alike, is no part a bending missed.
    Nor is structure a flexible nuisance takes beside it (``beside``: the space with ``nuisance.smooth_effect`` in
    the residual's leading variables, ``_smooth_beside``): an effect of the slide's states alone (``_in_states_alone``:
    a lead screw, a backlash, tau(x)) that keeps clear evidence in the final model beside that nuisance, fitted to
    ``judged_on`` (the search's last screen; ``data`` itself when not screened), is no part of what the nuisance holds
    (validation study seed 2026 case 63: a lead screw's period in x beside a re-absorption's misfit in time, in every
    hot sweep it acts on; a week's log, where the equivalent circuit's misfit at close range stands thousands of
    standard deviations beside a backlash and a lead screw fitted to within 12 % and 1 % of the lab's). An effect
    of time or temperature is not asked: the nuisance's splines are too coarse for its course (seed 2026 case 20: a
    drying and a conductivity change that took parts of a drift of the bridge's gain kept their evidence beside the
    smooth in time).
    Tie representatives stay as they are. ``acting``: where each step's effect acts (``_where_each_acts``)."""
    final = steps[-1].fit.residuals_ppm
    flagged: list[tuple[Step, float]] = []
    for (before, step), acts in zip(pairwise(steps), acting, strict=True):
        if step.stands_for or step.beside:
            continue
        left = residual_structure(data, beyond_idle_states(data, final, acts), noise, rows=acts)
        gain = _gain_on(data, step.added_from(before))
        if left.beyond(STRUCTURE_SIGNIFICANCE) and left.excess_chi2 > PARTIAL_SHARE * gain:
            flagged.append((step, left.significance))
    asked = [] if beside is None else [step.effects[-1] for step, _ in flagged
                                       if _in_states_alone(step.effects[-1], steps[-1], data, noise)]
    held: set[str] = set()
    if asked and beside is not None:
        # fits from the final model's solution, near the answer: a polish (``fit_model``), stopped at a negligible step
        held_where = _settled_only(steps[-1].fit)
        with_nuisance = fit_model(beside.model([*steps[-1].effects, NUISANCE]), judged_on, start=steps[-1].fit.values,
                                  fixed=held_where, multistart=False, screening=True, polish=True, noise_ppm=noise.ppm)
        holds = forked.each(lambda name: _holds_beside(name, steps[-1], beside, judged_on, noise, with_nuisance,
                                                       held_where), asked)
        held = {name for name, kept in zip(asked, holds, strict=True) if kept}
    for step, significance in flagged:
        if step.effects[-1] not in held:
            step.leaves_structure = significance


def _gain_on(data: Measurements, candidate: Candidate) -> float:
    """The candidate's chi-square gain counted over ``data``'s readings: made on a screen (a subsample, the
    candidate's fitted readings), it grows with the readings the screen stands for (a week's log of 10^4 readings
    judged its claims on 2,500 of them, and compared that gain with the structure left on all 10^4)."""
    rows = len(candidate.fit.residuals_ppm)
    return candidate.chi2_gain * (len(data) / rows if rows else 1.0)


def _smoothed_variables(associations: Sequence[Association]) -> list[str]:
    """The variables the nuisance smooth of a residual outside the library runs in: those of its first
    SMOOTH_ASSOCIATIONS associations that a smooth can take, beyond chance."""
    return [a.variable for a in associations[:SMOOTH_ASSOCIATIONS]
            if a.variable in SMOOTHABLE and a.significance > STRUCTURE_SIGNIFICANCE]


def _smooth_beside(data: Measurements, associations: Sequence[Association], space: _Space) -> _Space | None:
    """The search's space with the flexible nuisance that takes a residual outside the library (``nuisance.
    smooth_effect`` over ``data``'s ranges, in the variables of its first SMOOTH_ASSOCIATIONS associations beyond
    chance), as ``_beside_smooth`` judges candidates beside it; None where there is none."""
    variables = _smoothed_variables(associations)
    smooth = smooth_effect(data, variables) if variables else None
    return None if smooth is None else _Space(space.sensor, space.registry.with_effects(smooth), space.released)


def _in_states_alone(name: str, final: Step, data: Measurements, noise: NoiseEstimate) -> bool:
    """Whether the claimed effect ``name`` acts in the final model as a function of the slide's state alone
    (frequency, direction, commanded distance): its action there (ppm: the prediction against the same with its size
    parameters zero, ``checks.effect_action``) differs within no state by more than SIGNATURE_SHARE
    of the state's smallest noise or STATE_SHARE of its largest size there: it does not change with time or the
    temperatures, but for the few percent the sensitivity it shows through does (a lead screw's -245 ppm at 20 mm is
    -268 ppm with the coil at 120 C)."""
    fit = final.fit
    action = effect_action(fit, fit.model.effect(name), data)
    if not np.isfinite(action).all():  # no prediction without it (a lag of zero time constant): its action unknown
        return False
    state = _measuring_states(data)
    count = state.max() + 1
    low, high, size, sigma = np.full(count, np.inf), np.full(count, -np.inf), np.zeros(count), np.full(count, np.inf)
    np.minimum.at(low, state, action)
    np.maximum.at(high, state, action)
    np.maximum.at(size, state, np.abs(action))
    np.minimum.at(sigma, state, noise.sigma_ppm(data))
    return bool(np.all(high - low <= np.maximum(SIGNATURE_SHARE * sigma, STATE_SHARE * size)))


def _settled_only(fit: FitResult) -> dict[str, float]:
    """The parameters ``fit`` leaves undetermined or on a bound, at their values: a fit from its solution holds them
    there (a drying's sorption width with a standard error of 1e15 K, on its bound: the solver crept along it for
    the whole of its budget, 3 s a fit on 2,500 readings)."""
    return {name: fit.values[name] for name in fit.free_names
            if parameter_status(fit, name).label in (AT_BOUND, UNDETERMINED)}


def _holds_beside(name: str, final: Step, beside: _Space, data: Measurements, noise: NoiseEstimate,
                  full: FitResult, held: Mapping[str, float]) -> bool:
    """Whether the claimed effect ``name`` keeps clear evidence (``checks.clear_evidence``) in the final model beside
    the nuisance of ``beside``: that model fitted with the nuisance (``full``) against the same without ``name``,
    with the parameters ``full`` held (``held``: ``_settled_only``) at the same values."""
    model = beside.model([*(e for e in final.effects if e != name), NUISANCE])
    names = {p.name for p in model.parameters()}
    without = fit_model(model, data, start={k: v for k, v in full.values.items() if k in names},
                        fixed={k: v for k, v in held.items() if k in names}, multistart=False, screening=True,
                        polish=True, noise_ppm=noise.ppm)
    return clear_evidence(score_candidate(name, full, without, noise, data, len(data)))


def beyond_idle_states(data: Measurements, residual: np.ndarray, acts: np.ndarray) -> np.ndarray:
    """``residual`` with, on the readings in ``acts``, the mean residual of the readings of the same state (frequency,
    direction, commanded distance) outside ``acts`` taken out, where there are such readings: what is left is what
    the readings where an effect acts show beyond the same states where it does not (validation study case 99: a
    metal object's bump in x, in the cold sweep as in the hot ones, made the bending for a tilt look partial)."""
    state = _measuring_states(data)
    idle = ~acts
    counts = np.bincount(state[idle], minlength=state.max() + 1)
    sums = np.bincount(state[idle], weights=np.asarray(residual, float)[idle], minlength=state.max() + 1).astype(float)
    shared = np.divide(sums, counts, out=np.zeros_like(sums), where=counts > 0)
    return np.where(acts, residual - shared[state], residual)


@per_readings
def _measuring_states(data: Measurements) -> np.ndarray:
    """The state (frequency, direction, commanded distance or the coil in air) of every reading, numbered; computed
    once per campaign (``per_readings``)."""
    x = np.where(np.isfinite(data.x_commanded_m), np.round(data.x_commanded_m, 6), -1.0)
    return row_labels(data.freq_hz, data.direction, x)


def _mark_drift(steps: list[Step], data: Measurements, noise: NoiseEstimate, acting: list[np.ndarray]) -> None:
    """With the final residual drifting in time (outside the library, time among its leading associations), an
    effect claimed on the way that keeps less than PARTIAL_SHARE of its gain once a slow drift of every reading is
    read where it does not act is taken out (``drift.gain_beside_drift``) may be a part of the drift: it is not
    claimed (``Step.part_of_drift``). A state's effect (a bending while the target is hot) switches with its state
    and keeps its gain; a bending fitted to the offset of a hot sweep that the readings in air around it show as
    well does not (validation study case 141)."""
    residuals = [whitened(_residuals_on(step, data), data, noise) for step in steps]
    for step, (r_before, r_after), acts in zip(steps[1:], pairwise(residuals), acting, strict=True):
        if step.stands_for or step.beside or step.leaves_structure is not None:
            continue
        gain = float(r_before @ r_before - r_after @ r_after)
        kept = gain_beside_drift(data, r_before, r_after, acts) if gain > 0 else None
        if kept is not None and kept < PARTIAL_SHARE * gain:
            step.part_of_drift = kept / gain


def _drift_alike(final: Step, noise: NoiseEstimate) -> list[str]:
    """Effects of the final round that would take the residual to the noise and failed only because a slow drift of
    every reading in time leaves what they take as well (``checks.BEYOND_DRIFT``: a backlash, where the sweeps of
    each direction come at other times): the residual is that effect or such a drift, not shown to lie outside the
    library."""
    return [c.effect for c in final.candidates if c.rmse_ppm <= ADEQUATE_RATIO * noise.ppm
            and c.failed == {BEYOND_DRIFT}]


def _undetermined(ranked: list[Candidate]) -> list[str]:
    """The candidates with clear evidence and a plausible size, no worse held out, whose size the data left open."""
    return [c.effect for c in ranked if c.checks.get("evidence") and c.checks.get("plausible")
            and c.checks.get("held_out", True) and not c.checks.get("identifiable")]


def _rival(best: Candidate, other: Candidate, current: Step, noise: NoiseEstimate) -> bool:
    """``other`` ties with the claim ``best``: as clear evidence and a plausible size, a chi-square gain the data
    cannot tell from the claim's, no worse held out, and the same part of the residual taken (``overlap``). Its
    parameters need not be determined on their own: an explanation as good as the claim's is a rival whether or
    not its size trades off with the baseline's. Two effects that each take a different part (a backlash the
    difference between the directions, tau_T(x) the difference between the frequencies) are no alternatives:
    the claim is added and the other is judged again beside it."""
    return (other.checks.get("evidence", False) and other.checks.get("plausible", False)
            and other.checks.get("held_out", True) and tied(best, other)
            and overlap(best, other, current, noise) >= RIVAL_OVERLAP)


def overlap(a: Candidate, b: Candidate, current: Step, noise: NoiseEstimate) -> float:
    """The share of ``b``'s change of the prediction that ``a``'s change makes as well: cos^2 of the angle between
    the two changes of the residual (each reading weighed by its noise), both from the current model on the same
    readings (1: the same explanation; 0: explanations of different readings or different patterns)."""
    data = a.fit_data
    if data is None or data is not b.fit_data:
        return 1.0
    before = whitened(_residuals_on(current, data), data, noise)
    change_a = before - whitened(a.fit.residuals_ppm, data, noise)
    change_b = before - whitened(b.fit.residuals_ppm, data, noise)
    norms = float(np.linalg.norm(change_a) * np.linalg.norm(change_b))
    return float(change_a @ change_b) ** 2 / norms**2 if norms > 0 else 1.0


def _explains_well(best: Candidate, screen: Measurements, current: Step, noise: NoiseEstimate) -> bool:
    """A tied group's best member explains the residual well: it takes at least GOOD_SHARE of the structure
    a flexible smooth of the current residual finds beyond chance, or leaves no such structure behind."""
    before = residual_structure(screen, _residuals_on(current, screen), noise)
    after = residual_structure(screen, best.fit.residuals_ppm, noise)
    taken = before.excess_chi2 - after.excess_chi2
    return taken >= GOOD_SHARE * before.excess_chi2 or not after.beyond(STRUCTURE_SIGNIFICANCE)


def _residuals_on(step: Step, data: Measurements) -> np.ndarray:
    """The step's residual on ``data``: its fit's own, or on the screening subsample its round refitted it on, that
    refit's (what the round's candidates changed)."""
    if step.on_screen is not None and step.on_screen[0] is data:
        return step.on_screen[1].residuals_ppm
    if len(step.fit.residuals_ppm) == len(data):
        return step.fit.residuals_ppm
    return (data.ls_h / step.fit.predict(data) - 1) * 1e6


def _robust_fit(data: Measurements, effects: list[str], space: _Space, screen_rows: int,
                given: FitResult | None = None
                ) -> tuple[Measurements, FitResult, NoiseEstimate, list[Outlier], list[str]]:
    """Fit (or take ``given``, the caller's fit of the same model to ``data``), flag glitches, exclude them and
    refit until none is new; then free the baseline parameters the data determine. The clean data, the fit,
    its noise, the glitches and the parameters released."""
    model = space.model(effects)
    index = np.arange(len(data))
    clean = data
    if given is not None and (given.effects != effects or given.n != len(data)):
        raise ValueError(f"the fit given to the diagnosis is of {given.effects or 'the baseline'} on {given.n} "
                         f"readings, not of {effects or 'the baseline'} on these {len(data)}")
    if given is not None and len(data) <= screen_rows:  # the very fit the line below would make
        fitted = dataclasses.replace(given, model=model)
    elif given is not None:  # its global search was made on every reading: the polish starts there
        fitted = fit_model(model, clean, start=given.values, multistart=False, screening=True)
    elif len(data) > screen_rows:  # the global search on a subsample, the polish on every reading
        sample = fit_model(model, screened(data, screen_rows))
        fitted = fit_model(model, clean, start=sample.values, multistart=False, screening=True)
    else:
        fitted = fit_model(model, clean)
    noise = fitted.noise  # the fit's own estimate: fit and diagnose report the same noise
    outliers: list[Outlier] = []
    reweighted = False
    for _ in range(MAX_OUTLIER_ROUNDS):
        # Each reading judged against its own phase's noise; the refits are robust (Huber's loss), so a glitch the
        # rules leave does not bend the model toward it and make its neighbours look like glitches.
        sigma = noise.reading_sigma_ppm(clean)
        glitches = find_glitches(clean, fitted.residuals_ppm, sigma)
        if not glitches.any() or glitches.sum() > 0.02 * len(clean) + 2:
            break
        outliers += describe(clean, np.flatnonzero(glitches), fitted.residuals_ppm, sigma, index, outliers, data)
        keep = ~glitches
        clean, index = clean.select(keep), index[keep]
        fitted, reweighted = _robust_refit(model, clean, fitted, noise, screen_rows * SCREEN_GROWTH)
        noise = fitted.noise  # the fit's own estimate: fit and diagnose report the same noise
    if reweighted:  # the current model as the candidates are fitted (least squares)
        fitted = fit_model(model, clean, start=fitted.values, multistart=False, screening=True)
        noise = fitted.noise
    outliers.sort(key=lambda o: o.row)
    fitted, released = _released(fitted, clean, effects, space)
    return clean, fitted, fitted.noise, outliers, released


def _robust_refit(model: SensorModel, clean: Measurements, fitted: FitResult, noise: NoiseEstimate, limit: int
                  ) -> tuple[FitResult, bool]:
    """The robust refit after a glitch exclusion, and whether it was reweighted (Huber's loss). On more than
    ``limit`` readings its reweighting is solved on a random subsample of that many (``screened``) and evaluated on
    every reading, its noise estimated anew there: the glitch rules judge a reading against a running median of its
    series, which a solution from a fifth of the readings moved by at most 0.13 sigma (docs/diagnosis.md), and a
    dozen reweighted solves on every reading were three quarters of the robust start (7.6 of 10 s at 10^5)."""
    sample = screened(clean, limit)
    robust = fit_model(model, sample, start=fitted.values, multistart=False, screening=True, noise=noise,
                       robust=True)
    reweighted = robust.loss_scale_ppm is not None
    return (robust if sample is clean else evaluated(robust, clean, noise_anew=True)), reweighted


def _released(fitted: FitResult, data: Measurements, effects: list[str], space: _Space
              ) -> tuple[FitResult, list[str]]:
    """The fit with the baseline parameters the rules fixed but the data determine set free (kept free
    only where the fit confirms a standard error below half the value), and their names."""
    sample = screened(data, SCREEN_ROWS)
    rows = fit_model(fitted.model, sample, start=fitted.values, multistart=False, screening=True) \
        if sample is not data else fitted
    names = releasable(fitted.model, sample, fitted.values, rows.free_names, fitted.fixed, fitted.noise)
    if not names:
        return fitted, []
    model = ReleasedModel(space.sensor, effects, space.registry, frozenset(names))
    trial = fit_model(model, data, start=fitted.values, multistart=False)
    kept = [n for n in names if n in trial.free_names and trial.stderr.get(n, math.inf) < 0.5 * abs(trial.values[n])]
    if not kept:
        return fitted, []
    if kept != names:
        model = ReleasedModel(space.sensor, effects, space.registry, frozenset(kept))
        trial = fit_model(model, data, start=trial.values, multistart=False)
    return trial, kept


def default_candidates(registry: EffectRegistry, sensor: SensorConfig | None = None) -> list[str]:
    """The effects a diagnosis tries unless told which: those of ``registry`` tried by default
    (``Effect.tried_by_default``) that can act on ``sensor`` (``Effect.applies_to``; default: the paper's prototype)."""
    sensor = sensor or SensorConfig()
    return [n for n in registry if registry[n].tried_by_default and registry[n].applies_to(sensor)]


def _absorbed_at_every_shape(model: SensorModel, data: Measurements, current: Mapping[str, float],
                             start: Mapping[str, float] | None, space: np.ndarray, noise: NoiseEstimate,
                             held: Sequence[str] = ()) -> str | None:
    """Why the last effect of ``model`` is untestable (``absorbed``) at its start and at each alternative start
    that only reshapes it (sets nuisance parameters alone: a plate's thickness), or None when any is testable: a
    conductivity change seen through a sheet's tau_T vanishes once tau_T screens fully, through a thick plate's
    skin recession it does not."""
    effect = model.effects[-1]
    shapes = [dict(start or {})] + [dict(start or {}, **alt) for alt in effect.alternative_starts
                                    if alt and set(alt) <= set(effect.nuisance_parameters)]
    why = None
    for shape in shapes:
        why = absorbed(model, data, start_values(model, {**current, **shape}), space, noise, held)
        if why is None:
            return None
    return why


def _round(screen: Measurements, clean: Measurements, current: Step, names: list[str], models: _Space,
           noise: NoiseEstimate, folds: np.ndarray | None, current_cv: float | None = None,
           work: _RoundWork | None = None) -> tuple[list[Candidate], dict[str, str], float | None]:
    """Fit and check every candidate against the current model; ranked best first (passing ones
    first, then by evidence). Also: candidates these data cannot test (name -> why), and the
    current model's held-out error. ``work``: what rounds on this model and screen worked out already, reused
    and added to (``_RoundWork``)."""
    work = _RoundWork.kept(work, screen, current)
    if screen is clean:
        base = current.fit
    elif current.on_screen is not None and current.on_screen[0] is screen:
        base = current.on_screen[1]
    else:
        base = _refitted_on(screen, current.fit)
        current.on_screen = (screen, base)
    ranked, untestable = [], {}
    shift_m, shift_weights = _distance_error(base, screen, noise)
    held = held_nuisances(base.model, screen)
    space = calibration_space(base.model, screen, base.values, base.free_names, noise, held)

    def tried(name: str) -> Candidate | str:
        """The candidate fitted, or why these data cannot test it."""
        model = models.model([*current.effects, name])
        effect = model.effects[-1]
        fixed = model.unidentifiable(screen)
        keys = effect.key_names()
        if all(k in fixed for k in keys):
            return "; ".join(sorted({fixed[k] for k in keys}))
        from_residual = effect.starts_from_residual(screen, shift_m, shift_weights)
        start = from_residual[0] if from_residual else None
        why = _absorbed_at_every_shape(model, screen, base.values, start, space, noise, held)
        if why is not None:
            return why
        candidate = _candidate(screen, model, name, base, noise, len(clean), start)
        candidate.from_residual = [dict(s) for s in from_residual[1:]]
        return candidate

    untried = [name for name in names if name not in work.tried]
    work.tried.update(zip(untried, forked.each(tried, untried, shared=(clean, *models.shared(screen))), strict=True))
    for name in names:
        outcome = work.tried[name]
        if isinstance(outcome, str):
            untestable[name] = outcome
        else:
            ranked.append(_unchecked(outcome))
    ranked.sort(key=evidence_rank)
    # Alternative starts where another valley could change the outcome: not once the model is at the
    # noise, and not for candidates far behind the leader; once the leader is at the noise, only for
    # those close enough to tie with it (a tie is judged between each candidate's best fits). A candidate
    # whose fit ran into a wall (``_walled``) is refitted however far behind: its gain says nothing of its valley.
    leader_gain = max((c.chi2_gain for c in ranked), default=0.0)
    solved = any(c.rmse_ppm <= ADEQUATE_RATIO * noise.ppm and not c.not_better for c in ranked[:1])
    if current.rmse_ppm > ADEQUATE_RATIO * noise.ppm:
        leading = [i for i, candidate in enumerate(ranked[:LEADING])
                   if (candidate.not_better and not solved) or (candidate.rmse_ppm > ADEQUATE_RATIO * noise.ppm and (
                       candidate.chi2_gain >= (TIE_REACH if solved else 0.1) * leader_gain or _walled(candidate)))]
        unrefined = [ranked[i] for i in leading if ranked[i].effect not in work.refined]
        work.refined.update((c.effect, refined) for c, refined in
                            zip(unrefined, _refined(screen, unrefined, base, noise, len(clean)), strict=True))
        for i in leading:
            ranked[i] = _unchecked(work.refined[ranked[i].effect])
    for candidate in ranked:
        check_candidate(candidate)
        if candidate.passes and candidate.effect_object.in_time_alone:
            if id(candidate.fit) not in work.in_time:
                work.in_time[id(candidate.fit)] = _in_time_alone(candidate.fit, screen)
            check_in_time(candidate, work.in_time[id(candidate.fit)], noise, screen, len(clean))
        if candidate.passes and candidate.effect_object.drift_leaves_it:
            if id(candidate.fit) not in work.beside_drift:
                work.beside_drift[id(candidate.fit)] = _beside_drift(candidate, base, screen, models)
            drifting = work.beside_drift[id(candidate.fit)]
            if drifting is not None:
                check_beyond_drift(candidate, *drifting, noise, screen, len(clean))
    ranked.sort(key=lambda c: (not c.passes, evidence_rank(c)))
    base_cv = first_cv = None
    if folds is not None and ranked and ranked[0].passes:  # the previous round's claim already has its own
        # the current model's held-out error and the first candidate's (checked first below), side by side
        known = work.cv.get(id(ranked[0].fit))
        if current_cv is not None and known is not None:
            base_cv, first_cv = current_cv, known
        else:
            scores = cv_rmses(screen, [ranked[0].fit] if current_cv is not None else [base, ranked[0].fit], folds)
            base_cv, first_cv = current_cv if current_cv is not None else scores[0], scores[-1]
    leader = None
    for candidate in ranked:  # held-out error, lazily: for the leader and whatever might tie with it
        if not candidate.passes or folds is None:
            continue
        if leader is not None and not tied(leader, candidate):
            continue
        check_held_out(candidate, base_cv, folds, screen, noise,
                       first_cv if candidate is ranked[0] else work.cv.get(id(candidate.fit)))
        work.cv[id(candidate.fit)] = candidate.cv_rmse_ppm
        if candidate.passes and leader is None:
            leader = candidate
    ranked.sort(key=lambda c: (not c.passes, evidence_rank(c)))
    work.base_cv = base_cv if base_cv is not None else work.base_cv
    return ranked, untestable, base_cv


@dataclass
class _RoundWork:
    """What the rounds on one current model and screening subsample worked out: each candidate as fitted (or why
    it is untestable), each as refined, each one's held-out error, and the current model's. A round after a claim
    dropped on every reading, or a partial group set aside, weighs the same model on the same readings, and the
    fits it would make are the ones made already (the same inputs, the same results)."""

    screen: Measurements
    step: Step
    tried: dict[str, Candidate | str] = dataclasses.field(default_factory=dict)
    refined: dict[str, Candidate] = dataclasses.field(default_factory=dict)
    #: held-out errors by the fit's identity (the fits themselves are kept in ``tried`` and ``refined``)
    cv: dict[int, float | None] = dataclasses.field(default_factory=dict)
    #: each passing fit's model refitted with its course in time alone (``_in_time_alone``), by the fit's identity
    in_time: dict[int, FitResult] = dataclasses.field(default_factory=dict)
    #: each such fit's current model with a linear drift in time, without and with its effect (``_beside_drift``)
    beside_drift: dict[int, tuple[FitResult, FitResult] | None] = dataclasses.field(default_factory=dict)
    base_cv: float | None = None

    @classmethod
    def kept(cls, work: _RoundWork | None, screen: Measurements, step: Step) -> _RoundWork:
        """``work`` if it is for this step on this screen, else a new, empty one."""
        return work if work is not None and work.screen is screen and work.step is step else cls(screen, step)


def _in_time_alone(fitted: FitResult, data: Measurements) -> FitResult:
    """``fitted``'s model refitted to ``data`` with its last effect's course in time alone (``Effect.in_time_alone``),
    what the fit held still held: the best from its solution and from the effect's other starts of the values that
    form leaves free (a pace fitted to the hot readings alone need not be the pace of every reading)."""
    effect = fitted.model.effects[-1]
    form = effect.in_time_alone
    fixed = {**{k: v for k, v in fitted.values.items() if k not in fitted.free_names}, **form}
    starts: dict[tuple[tuple[str, float], ...], dict[str, float]] = {}
    for alternative in ({}, *effect.alternative_starts):
        start = {k: v for k, v in alternative.items() if k not in form}
        starts.setdefault(tuple(sorted(start.items())), start)
    fits = forked.each(lambda start: fit_model(fitted.model, data, start={**fitted.values, **start, **form},
                                               fixed=fixed, multistart=False, screening=True),
                       list(starts.values()), shared=referenced(data, fitted.model))
    return min(fits, key=lambda fit: fit.rms_ppm)


def _beside_drift(candidate: Candidate, base: FitResult, data: Measurements, models: _Space
                  ) -> tuple[FitResult, FitResult] | None:
    """The current model (``base``) refitted to ``data`` beside a straight-line drift of every reading in time
    (``nuisance.linear_drift_effect``), and that model with ``candidate``'s effect too, from its values; None when the
    readings span no time, or beside the nuisance smooth (``_beside_smooth``), which takes a slow drift already. The
    two fits are worked side by side (``forked.each``)."""
    drift = linear_drift_effect(data)
    effects = [effect.name for effect in base.model.effects]
    if drift is None or NUISANCE in effects:
        return None
    beside = _Space(models.sensor, models.registry.with_effects(drift), models.released)
    own = {p.name: candidate.fit.values[p.name] for p in candidate.effect_object.parameters()}
    models_and_starts = [(beside.model([*effects, NUISANCE]), dict(base.values)),
                         (beside.model([*effects, NUISANCE, candidate.effect]), {**base.values, **own})]
    drifting, with_it = forked.each(lambda task: fit_model(task[0], data, start=task[1], multistart=False,
                                                           screening=True),
                                    models_and_starts, shared=beside.shared(data))
    return drifting, with_it


def _unchecked(candidate: Candidate) -> Candidate:
    """A fresh copy of ``candidate`` for a round's checks to fill (``check_candidate``, ``check_held_out``)."""
    return dataclasses.replace(candidate, checks={}, rejected=[], cv_rmse_ppm=None, base_cv_rmse_ppm=None,
                               held_out_gain=None, from_residual=list(candidate.from_residual))


def _refitted_on(screen: Measurements, fitted: FitResult) -> FitResult:
    """The current model refitted on the screening subsample from its solution on every reading, its free
    parameters as they were there (where no refit there came with it: the baseline's, a repolish's winner's; a
    claim's own is refitted there beside its refit on every reading, ``_full_fit_beside_starts``). A candidate
    fitted on the subsample is weighed against this fit, not against the solution on every reading evaluated there:
    that solution is not the subsample's best, and the gain of refitting it there alone (chi-square 19.5, BIC -7.9
    on the first round of the faithful 10^5-reading campaign, against thresholds of 25 and -10) was counted as every
    candidate's evidence."""
    held = {name: value for name, value in fitted.values.items() if name not in fitted.free_names}
    return fit_model(fitted.model, screen, start=fitted.values, fixed=held or None, multistart=False, screening=True)


def _walled(candidate: Candidate) -> bool:
    """The fit left one of the effect's nuisance parameters (``Effect.nuisance_parameters``, the shape the search
    knows to be valley-prone) at a bound while the effect has other starts: it ran into a wall on its way from the
    default start (a plate's thickness to its thinnest, where the conductivity change acts through tau_T alone), not
    into the valley those starts reach (the thick plate's skin recession). Key parameters at a bound fail the
    identifiability check anyway; secondary ones (a drying's widths) are not refitted for: each refit from a dozen
    starts doubled a coil-heated campaign's diagnosis and changed no verdict of the validation study."""
    effect = candidate.effect_object
    return bool(effect.alternative_starts) and any(at_bound(candidate.fit, name) for name in effect.nuisance_parameters
                                                   if name in candidate.fit.values)


def _candidate(data: Measurements, model: SensorModel, name: str, base: FitResult, noise: NoiseEstimate,
               n_full: int, start: dict[str, float] | None = None) -> Candidate:
    """Fit model + effect from the current solution (and the effect's defaults or ``start``)."""
    own = {p.name for p in model.effects[-1].parameters()}
    values = {k: v for k, v in base.values.items() if k not in own}
    fitted = fit_model(model, data, start={**values, **(start or {})}, multistart=False, screening=True)
    fitted = _unreleased(fitted, base, data)
    candidate = score_candidate(name, fitted, base, noise, data, n_full)
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


def _refined(data: Measurements, candidates: Sequence[Candidate], base: FitResult, noise: NoiseEstimate,
             n_full: int) -> list[Candidate]:
    """Leading candidates not yet at the noise level, each refitted from its effect's alternative starts and those
    it read off the residual (``Candidate.from_residual``): the best fit of each.

    With more starts than SCOUTS_REFITTED, each is first scouted with only the effect's own parameters
    free (the current model held where it is: a few columns instead of all), and the whole model is
    refitted from the best scouts
    (a valley whose depth shows only with the model free, a plate's thickness against tau_T, say,
    need not lead the scouts). The fits of every candidate are worked side by side (``forked.each``): the scouts
    and the refits that need none first, then the refits from the scouts."""
    models = [candidate.fit.model for candidate in candidates]
    owns = [[p.name for p in model.effects[-1].parameters()] for model in models]
    starts = [[dict(alternative) for alternative in (*model.effects[-1].alternative_starts, *candidate.from_residual)]
              for model, candidate in zip(models, candidates, strict=True)]
    scouted = [len(each_start) > SCOUTS_REFITTED for each_start in starts]

    def scout(which: int, start: dict[str, float]) -> FitResult:
        held = {k: v for k, v in base.values.items() if k not in owns[which]}
        return fit_model(models[which], data, start=start, fixed=held, multistart=False, screening=True)

    def trial(which: int, start: dict[str, float]) -> Candidate:
        return _candidate(data, models[which], candidates[which].effect, base, noise, n_full, start)

    shared = [obj for model in models for obj in referenced(data, model)]
    first = [(which, start) for which in range(len(candidates)) for start in starts[which]]
    done = forked.each(lambda task: (scout if scouted[task[0]] else trial)(*task), first, shared=shared)
    firsts: list[list[Any]] = [[] for _ in candidates]
    for (which, _), outcome in zip(first, done, strict=True):
        firsts[which].append(outcome)
    trials = [[] if scouted[which] else firsts[which] for which in range(len(candidates))]
    second = [(which, {name: fit.values[name] for name in owns[which]})
              for which in range(len(candidates)) if scouted[which]
              for fit in sorted(firsts[which], key=lambda f: f.rms_ppm)[:SCOUTS_REFITTED]]
    for (which, _), outcome in zip(second, forked.each(lambda task: trial(*task), second, shared=shared),
                                   strict=True):
        trials[which].append(outcome)
    best = list(candidates)
    for which, tried in enumerate(trials):
        for outcome in tried:
            if outcome.fit.rms_ppm < best[which].fit.rms_ppm:
                best[which] = outcome
    return best


@dataclass
class _ScreenStart:
    """The claimed model on the screening subsample: the subsample, the model refitted there from the candidate's own
    solution (the next round's current model there, and where a repolish starts, ``_repolished``), and the
    repolish's first alternative starts already tried (None: not yet)."""

    screen: Measurements
    fit: FitResult
    first: list[FitResult] | None
    #: the fit's held-out error on the subsample (ppm; None: not cross-validated)
    cv_rmse_ppm: float | None = None


def _full_fit_beside_starts(clean: Measurements, candidate: Candidate, earlier: int, screen: Measurements,
                            folds: np.ndarray | None, noise_ppm: float | None = None
                            ) -> tuple[FitResult, _ScreenStart | None]:
    """The claim refitted on every reading (``_full_fit``) and, on a screened campaign, the claimed model refitted
    on the screening subsample from the candidate's own solution, not from the refit's (``_ScreenStart``): what the
    next round weighs its candidates against, with its held-out error there (on ``folds``), and where a repolish
    tries the starts of the ``earlier`` effects (``_repolished``). So, with processes to share them (``forked``),
    those folds and starts are fitted on the subsample while this process refits every reading
    (``forked.each_beside``): alone, the refit left a CPU idle for a second of every claim at 10^5 readings.
    ``noise_ppm`` as for ``_polished``."""
    if screen is clean:
        return _full_fit(clean, candidate, noise_ppm), None
    model = candidate.fit.model
    on_screen = fit_model(model, screen, start=candidate.fit.values, multistart=False, screening=True)
    starts = _restart_tasks(model, earlier) if forked.workers() > 1 else []
    held_out = HeldOutFits(screen, [on_screen], folds) if folds is not None else None
    fold_tasks = held_out.tasks() if held_out is not None else []

    def fitted(task: tuple[str, Any]) -> Any:
        kind, what = task
        if kind == "fold":
            assert held_out is not None
            return held_out.squares(what)
        return _tried(model, screen, on_screen, what, scout_budget=REPOLISH_SCOUT_BUDGET)

    refit, done = forked.each_beside(lambda: _full_fit(clean, candidate, noise_ppm), fitted,
                                     [("start", task) for task in starts] + [("fold", task) for task in fold_tasks],
                                     shared=referenced(screen, model))
    assert refit is not None
    cv = held_out.rmses(done[len(starts):])[0] if held_out is not None else None
    return refit, _ScreenStart(screen, on_screen, done[:len(starts)] if starts else None, cv)


def _repolished(fitted: FitResult, data: Measurements, earlier: int,
                start: _ScreenStart | None = None, noise_ppm: float | None = None) -> FitResult:
    """The new model refitted from the alternative starts of the effects found before the one just added
    (the last ``earlier`` effects before it): a valley an earlier effect settled in alone (a plate's
    thickness, say) may not be the best once the new effect takes its share. The better fit is kept.

    On a screened campaign the starts are tried on the screening subsample, from ``start``
    (``_full_fit_beside_starts``; None on a campaign not screened), and only a start that wins there is polished
    on every reading (kept if better there too): a dozen full refits of every reading cost minutes at 10^6
    readings. ``noise_ppm`` as for ``_polished``."""
    if earlier <= 0:
        return fitted
    if start is None:
        return _best_start(fitted, data, earlier, fitted)
    best = _best_start(start.fit, start.screen, earlier, fitted, start.first)
    if best is start.fit:
        return fitted
    trial = _polished(fitted.model, data, best.values, noise_ppm)
    return trial if trial.rms_ppm < fitted.rms_ppm * (1 - 1e-3) else fitted


def _held(repolished: FitResult, checked: FitResult, name: str, current: FitResult, noise: NoiseEstimate,
          clean: Measurements) -> FitResult:
    """The repolish's fit where the claim ``name`` passes its checks there too, else the fit it was checked on: a
    claim is made with a fit it was checked at. (A repolish moved a drying's onset to 172 C and took tau_T(x) on
    one frequency from 161 to 45 ppm with a knot at its bound, and the claim was made at that fit unchecked.)"""
    if repolished is checked or _confirmed(name, repolished, current, noise, clean).passes:
        return repolished
    return checked


#: One alternative start of a repolish (``_restart_tasks``): the parameters its scout frees (None: tried with the
#: whole model free) and the start's values.
_Restart = tuple[frozenset[str] | None, dict[str, float]]


def _restart_tasks(model: SensorModel, earlier: int) -> list[_Restart]:
    """The alternative starts of the ``earlier`` effects before the last of ``model``, in order; those of an effect
    with more than SCOUTS_REFITTED of them scouted (``_tried``) with its own parameters free, as ``_refined`` scouts a
    candidate's: a drying's five shapes and a lead screw's six leads, each tried with the whole model free beside
    every claim after them, were a sixth of a 10^5-reading campaign's diagnosis (5 to 7 s), and won nothing."""
    tasks: list[_Restart] = []
    for effect in model.effects[-1 - earlier:-1]:
        starts = effect.alternative_starts
        own = frozenset(p.name for p in effect.parameters()) if len(starts) > SCOUTS_REFITTED else None
        tasks += [(own, dict(alternative)) for alternative in starts]
    return tasks


def _tried(model: SensorModel, data: Measurements, base: FitResult, task: _Restart,
           scout_budget: int | None = None) -> FitResult:
    """``model`` fitted to ``data`` from ``base``'s solution with the start of ``task`` in place: with the whole
    model free, or as a scout with only its parameters free and the rest held at ``base``'s solution, stopped after
    ``scout_budget`` evaluations per parameter if given (``fit_model``'s ``budget``)."""
    own, alternative = task
    held = None if own is None else {name: value for name, value in base.values.items() if name not in own}
    return fit_model(model, data, start={**base.values, **alternative}, fixed=held, multistart=False, screening=True,
                     budget=None if own is None else scout_budget)


def _outcomes(model: SensorModel, data: Measurements, best: FitResult, batch: list[_Restart],
              first: list[FitResult] | None) -> list[FitResult | None]:
    """Each start of ``batch`` fitted with the whole model free from ``best``'s solution, or None: a scouted start
    whose scout is not among the best SCOUTS_REFITTED of its effect's (those are refitted with the model free from
    the scout's solution). ``first``: the batch's fits already made (``_full_fit_beside_starts``)."""
    shared = referenced(data, model)
    made = first if first is not None else forked.each(
        functools.partial(_tried, model, data, best, scout_budget=REPOLISH_SCOUT_BUDGET), batch, shared=shared)
    scouted: dict[frozenset[str], list[int]] = {}
    for i, (own, _) in enumerate(batch):
        if own is not None:
            scouted.setdefault(own, []).append(i)
    refitted = [i for rows in scouted.values() for i in sorted(rows, key=lambda i: made[i].rms_ppm)[:SCOUTS_REFITTED]]
    refits = forked.each(lambda i: _tried(model, data, best, (None, made[i].values)), refitted, shared=shared)
    full: list[FitResult | None] = [fit if own is None else None for (own, _), fit in zip(batch, made, strict=True)]
    for i, fit in zip(refitted, refits, strict=True):
        full[i] = fit
    return full


def _best_start(best: FitResult, data: Measurements, earlier: int, claimed: FitResult,
                first: list[FitResult] | None = None) -> FitResult:
    """``best`` or the best fit of its model on ``data`` from the alternative starts of the ``earlier`` effects
    before the last of ``claimed``'s model (``_restart_tasks``), each from the best so far (better by 0.1 % of the
    RMS to count).

    With processes to share them (``forked``), the starts are tried at once from the best so far, and after one that
    wins those behind it are tried again from it (a win is rare); in one process, each effect's starts in turn.
    ``first``: the first fits of every start at once from ``best``, made already (``_full_fit_beside_starts``)."""
    pending = _restart_tasks(claimed.model, earlier)
    while pending:
        at_once = len(pending) if forked.workers() > 1 or first is not None else _first_effect(pending)
        batch, pending = pending[:at_once], pending[at_once:]
        trials = _outcomes(claimed.model, data, best, batch, first)
        first = None
        won = next(((i, trial) for i, trial in enumerate(trials)
                    if trial is not None and trial.rms_ppm < best.rms_ppm * (1 - 1e-3)), None)
        if won is not None:
            best = won[1]
            pending = batch[won[0] + 1:] + pending
    return best


def _first_effect(pending: list[_Restart]) -> int:
    """How many of ``pending`` are the first effect's scouted starts (all of them), or 1 for a start tried alone."""
    own = pending[0][0]
    if own is None:
        return 1
    return next((i for i, (other, _) in enumerate(pending) if other != own), len(pending))


def _confirmed(name: str, refit: FitResult, current: FitResult, noise: NoiseEstimate, clean: Measurements
               ) -> Candidate:
    """A claim refitted on every reading, scored and checked there against the current model."""
    confirmed = score_candidate(name, refit, current, noise, clean, len(clean))
    confirmed.fit_data = clean
    check_candidate(confirmed)
    return confirmed


def _course_open(confirmed: Candidate) -> bool:
    """A claim checked on every reading with clear evidence and a plausible size but its own course left open there
    (``Effect.signature``): the subsample's valley of its course, not the data, may be what leaves it open."""
    spread = signature_spread(confirmed)
    return bool(_undetermined([confirmed])) and spread is not None and not spread < 1.0


def _from_own_starts(clean: Measurements, refit: FitResult, noise_ppm: float | None = None) -> FitResult:
    """``refit`` or, if better (by 0.1 % of the RMS, as a repolish's start), the claimed model refitted on every
    reading from its effect's alternative starts (``refit`` itself when it has none): each scouted with only the
    effect's own parameters free (the rest held where ``refit`` left them) on the largest screen (LARGEST_SCREEN
    readings: 24 s instead of 143 s at 10^6) and weighed on every reading, the best polished with the model free.
    For a claim whose course its refit on every reading left open (``_course_open``): a 2,500-reading subsample
    holds a few readings of a half-hour drying, and cannot tell its valleys apart (docs/diagnosis.md). ``noise_ppm``
    as for ``_polished``."""
    model = refit.model
    if not model.effects[-1].alternative_starts:
        return refit
    own = frozenset(p.name for p in model.effects[-1].parameters())
    sample = screened(clean, LARGEST_SCREEN)
    scouts = forked.each(functools.partial(_tried, model, sample, refit),
                         [(own, dict(start)) for start in model.effects[-1].alternative_starts],
                         shared=referenced(sample, model))
    if sample is not clean:  # each scout's valley as every reading sees it
        scouts = [evaluated(fit, clean) for fit in scouts]
    best = min(scouts, key=lambda fit: fit.rms_ppm)
    trial = _polished(model, clean, best.values, noise_ppm)
    return trial if trial.rms_ppm < refit.rms_ppm * (1 - 1e-3) else refit


def _full_fit(clean: Measurements, candidate: Candidate, noise_ppm: float | None = None) -> FitResult:
    """The claimed model on every reading, from the screening solution (itself, when no subsample was screened);
    ``noise_ppm`` as for ``_polished``."""
    if clean is candidate.fit_data:
        return candidate.fit
    # From the screening solution a polish to a relative cost change of 1e-8 is all the claim needs;
    # the last digits of a slow direction are not worth thousands of evaluations on every reading.
    return _polished(candidate.fit.model, clean, candidate.fit.values, noise_ppm)


def _polished(model: SensorModel, clean: Measurements, start: Mapping[str, float], noise_ppm: float | None = None
              ) -> FitResult:
    """``model`` polished on every reading from ``start`` (its solution on a subsample); on a campaign more than
    PRE_POLISH_GROWTH times the largest screen, polished on that screen first: a walk from a 2,500-reading valley is
    dozens of evaluations, each a second at 10^6 readings (at 10^5: 7-15 of them on every reading, 0.2 s each).
    With ``noise_ppm`` (the search's reading noise) a polish stops at a step that gains a negligible chi-square
    (``fitting.NEGLIGIBLE_CHI2``)."""
    if len(clean) > PRE_POLISH_GROWTH * LARGEST_SCREEN:
        start = fit_model(model, screened(clean, LARGEST_SCREEN), start=start, multistart=False, screening=True,
                          polish=True, noise_ppm=noise_ppm).values
    return fit_model(model, clean, start=start, multistart=False, screening=True, polish=True, noise_ppm=noise_ppm)


def _distance_error(result: FitResult, data: Measurements, noise: NoiseEstimate) -> tuple[np.ndarray, np.ndarray]:
    """The residual as a distance error (m) and its weights (1/variance, 1/m^2: each reading's noise over
    the sensitivity); NaN and 0 for the coil in air."""
    sensitivity = result.model.relative_sensitivity(data, result.values)
    finite = np.isfinite(data.x_m) & np.isfinite(sensitivity) & (np.abs(np.nan_to_num(sensitivity)) > 0)
    with np.errstate(all="ignore"):
        shift = np.where(finite, result.residuals_ppm * 1e-6 / sensitivity, np.nan)
        weights = np.where(finite, (sensitivity * 1e6 / noise.sigma_ppm(data)) ** 2, 0.0)
    return shift, np.nan_to_num(weights)


def residual_mm(result: FitResult, data: Measurements) -> np.ndarray:
    """Residual as a position error (mm): relative residual times L over the sensitivity dL/dx."""
    sensitivity = result.model.relative_sensitivity(data, result.values)
    with np.errstate(all="ignore"):
        out = result.residuals_ppm * 1e-6 / sensitivity * 1e3
    return np.where(np.isfinite(data.x_m) & (np.abs(sensitivity) > 0), out, np.nan)
