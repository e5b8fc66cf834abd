"""The competing models of an open question, each fitted to the campaign: the chain's model and its alternatives.

A tie: the diagnosis's final model with the effect that stands for the group swapped for each member. An effect
with evidence but undetermined size, or one the data cannot test yet: the final model without it and with it;
an untestable effect has no fitted size, so it enters at a plausible one (``hypothetical_size``) held fixed while
the model is fitted to the campaign (its calibration then takes what the data cannot tell from it). An effect with
clear evidence and an undetermined size is present; the question is its size: the rivals are the effect a standard
error either side of its fitted size (``size_rivals``). A held parameter is part of a rival's hypothesis and stays
held when the rival is refitted to a candidate's predicted readings.

A rival's fit is one point of what the campaign allows. Where a shape parameter (``Effect.nuisance_parameters``: a
plate's thickness) is left flat by the campaign, the prediction at that point is one arbitrary choice among many
equally good ones, and a separation at it can be off by orders of magnitude. So each such parameter is profiled on
the campaign (held at values stepping out from the fit, the rest refitted) to the ends of its Delta chi-square <= 1
interval within its bounds (``plausible_range``), and the rival is kept also at each profile point inside it
(``Rival.plausible``): the separation a candidate guarantees is the least over them (``discrimination``).

Every fit here weighs each reading by its own noise (``NoiseEstimate.sigma_ppm``) and counts chi-square in noise
variances over the readings' design effect, as the diagnosis's evidence does (docs/diagnosis.md).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ecds_lab.analysis.diagnosis import Diagnosis
from ecds_lab.analysis.diagnosis.identifiability import ReleasedModel
from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.model.sensor_model import SensorModel

#: Two sizes of an undetermined effect are rivals only while the campaign cannot tell them apart: each fits it
#: within this many noise variances of the best size (else the offsets are halved, at most SIZE_HALVINGS times).
TOLD_APART_CHI2 = 25.0
SIZE_HALVINGS = 8
#: A shape parameter's plausible range: where its profile on the campaign stays within this many noise variances of
#: the best fit (a 68 % profile-likelihood interval for one parameter).
PLAUSIBLE_CHI2 = 1.0
#: Profile steps: a positive parameter steps by this factor, any other by its prior scale times this less one; the
#: first step beyond the interval is bisected PROFILE_BISECTIONS times to place the end. sqrt(2): a plate's
#: thickness against the skin depth changes by it between frequencies a factor 2 apart (delta ~ f^-1/2), finer
#: than any of the station's frequencies are spaced.
PROFILE_FACTOR = math.sqrt(2.0)
PROFILE_BISECTIONS = 3
PROFILE_STEPS = 16


@dataclass
class Rival:
    """One competing model: its effects, its fitted values on the campaign and its chi-square there."""

    label: str
    effects: tuple[str, ...]
    model: SensorModel
    values: dict[str, float]
    chi2: float
    #: parameters held at a plausible size the data cannot determine (an untestable effect supposed present)
    held: dict[str, float] = field(default_factory=dict)
    #: the same hypothesis across its shape parameters' plausible ranges on the campaign (``plausible_range``, each
    #: point a refit with the parameter held there): the values the data allow as well as the fit's
    plausible: tuple[Rival, ...] = ()
    #: the hypothesis is the held size itself (``size_rivals``): it stays held when the rival is refitted to a joined
    #: campaign, where two sizes set free would meet at one
    sized: bool = False

    @property
    def plausible_ranges(self) -> dict[str, tuple[float, float]]:
        """Each profiled shape parameter's plausible range (low, high end) on the campaign."""
        out: dict[str, tuple[float, float]] = {}
        for variant in self.plausible:
            for name, value in variant.held.items():
                if name not in self.held:
                    low, high = out.get(name, (value, value))
                    out[name] = (min(low, value), max(high, value))
        return out

    def predict(self, data: Measurements) -> np.ndarray:
        """Ls (H) this model predicts for ``data``."""
        return self.model.predict(data, self.values)

    def to_json(self) -> dict[str, object]:
        return {"label": self.label, "effects": list(self.effects), "chi2": round(self.chi2, 1),
                "held": {k: float(f"{v:.4g}") for k, v in self.held.items()},
                "plausible": {k: [float(f"{low:.4g}"), float(f"{high:.4g}")]
                              for k, (low, high) in self.plausible_ranges.items()}}


def chi2_of(fit: FitResult, noise: NoiseEstimate) -> float:
    """A noise-weighted fit's chi-square in noise variances, over the design effect (as the diagnosis counts)."""
    return float(np.sum((fit.effective_residuals_ppm / noise.ppm) ** 2)) / max(noise.design_effect, 1.0)


def weighted_fit(model: SensorModel, data: Measurements, noise: NoiseEstimate, start: Mapping[str, float],
                 held: Mapping[str, float] | None = None) -> FitResult:
    """``model`` fitted to ``data`` from ``start``, each reading weighed by its noise; ``held`` fixed."""
    return fit_model(model, data, start=dict(start), fixed=dict(held or {}) or None, multistart=False,
                     screening=True, noise=noise)


def fitted_rival(label: str, effects: Sequence[str], result: Diagnosis, registry: EffectRegistry,
                 start: Mapping[str, float], held: Mapping[str, float] | None = None) -> Rival:
    """A rival model fitted (noise-weighted) to the diagnosis's clean readings."""
    model = ReleasedModel(result.final.fit.model.sensor, list(effects), registry, frozenset(result.released))
    names = {p.name for p in model.parameters()}
    start = {k: v for k, v in start.items() if k in names}
    fit = weighted_fit(model, result.data, result.evidence_noise, start, held)
    rival = Rival(label, tuple(effects), model, fit.values, chi2_of(fit, result.evidence_noise), dict(held or {}))
    return with_plausible(rival, result.data, result.evidence_noise)


def shape_parameters(rival: Rival, campaign: Measurements) -> list[str]:
    """The rival's shape parameters the campaign fits (``Effect.nuisance_parameters``, neither held by its
    hypothesis nor fixed by the model's rules on these data)."""
    fixed = rival.model.unidentifiable(campaign)
    names = dict.fromkeys(n for effect in rival.model.effects for n in effect.nuisance_parameters)
    return [n for n in names if n in rival.values and n not in rival.held and n not in fixed]


def _held_at(rival: Rival, name: str, value: float, campaign: Measurements, noise: NoiseEstimate) -> Rival:
    """``rival`` refitted to the campaign with ``name`` held at ``value`` (for that fit only)."""
    held = {**rival.held, name: value}
    fit = weighted_fit(rival.model, campaign, noise, {**rival.values, name: value}, held)
    return Rival(rival.label, rival.effects, rival.model, fit.values, chi2_of(fit, noise), held)


def plausible_range(rival: Rival, name: str, campaign: Measurements, noise: NoiseEstimate) -> list[Rival]:
    """The rival held at points across ``name``'s profile interval on the campaign: stepping out from the fit (by
    ``PROFILE_FACTOR``, within the parameter's bounds) while its chi-square stays within ``PLAUSIBLE_CHI2`` of the
    rival's, the first step beyond bisected to place the end. Every point inside is kept, not only the ends: a
    separation need not be monotonic in a shape parameter (a plate's thickness against the skin depth at the new
    frequency). A profile, not the linearised standard error: on a flat valley (a thin plate's thickness at one
    frequency) the latter is far too small."""
    parameter = next(p for p in rival.model.parameters() if p.name == name)
    points = []
    for direction in (-1, 1):
        bound = parameter.lower if direction < 0 else parameter.upper

        def step(x: float, direction: int = direction, bound: float = bound) -> float:
            if parameter.lower > 0:
                moved = x * PROFILE_FACTOR**direction
            else:
                moved = x + direction * (PROFILE_FACTOR - 1) * parameter.prior_scale
            return max(moved, bound) if direction < 0 else min(moved, bound)

        inside, outside = rival, None
        for _ in range(PROFILE_STEPS):
            x = step(inside.values[name])
            if x == inside.values[name]:
                break  # at the bound
            trial = _held_at(rival, name, x, campaign, noise)
            if not trial.chi2 - rival.chi2 <= PLAUSIBLE_CHI2:
                outside = trial
                break
            points.append(trial)
            inside = trial
        for _ in range(PROFILE_BISECTIONS if outside is not None else 0):
            a, b = inside.values[name], outside.values[name]  # type: ignore[union-attr]
            middle = math.sqrt(a * b) if parameter.lower > 0 else (a + b) / 2
            trial = _held_at(rival, name, middle, campaign, noise)
            if trial.chi2 - rival.chi2 <= PLAUSIBLE_CHI2:
                inside = trial
            else:
                outside = trial
        if inside is not rival and not any(inside is p for p in points):
            points.append(inside)
    return [p for p in points if math.isfinite(p.chi2)]


def with_plausible(rival: Rival, campaign: Measurements, noise: NoiseEstimate) -> Rival:
    """``rival`` with ``plausible``: itself across each shape parameter's plausible range (``plausible_range``)."""
    variants = [point for name in shape_parameters(rival, campaign)
                for point in plausible_range(rival, name, campaign, noise)]
    return dataclasses.replace(rival, plausible=tuple(variants))


def effect_start(result: Diagnosis, effect: str) -> dict[str, float]:
    """The values the diagnosis found for ``effect`` when it was a candidate (the last round that fitted it)."""
    for step in reversed(result.steps):
        for candidate in step.candidates:
            if candidate.effect == effect:
                return dict(candidate.fit.values)
    return {}


def hypothetical_size(registry: EffectRegistry, effect: str, sensor: SensorConfig) -> dict[str, float]:
    """A plausible size of ``effect``'s key parameters: each at its default when that is not zero (an effect
    that is on by default, e.g. a lag's time constant), else at its prior scale (the size of a plausible change)."""
    cls = registry.get(effect)
    if cls is None:
        return {}
    made = cls(sensor)
    keys = made.key_names()
    return {p.name: (p.value if p.value != 0 else p.prior_scale) for p in made.parameters() if p.name in keys}


def tie_rivals(result: Diagnosis, group: Sequence[str], registry: EffectRegistry) -> list[Rival]:
    """The final model with the group's representative replaced by each member."""
    final = list(result.final.effects)
    present = [name for name in group if name in final]
    rivals = []
    for member in group:
        effects = [member if name in present else name for name in final] if present else [*final, member]
        rivals.append(fitted_rival(f"{member}", effects, result, registry,
                                   {**result.final.fit.values, **effect_start(result, member)}))
    return rivals


def last_fit_of(result: Diagnosis, effect: str) -> FitResult | None:
    """The diagnosis's last fit of ``effect`` as a candidate (the round it was last tried in), or None."""
    return next((c.fit for step in reversed(result.steps) for c in step.candidates if c.effect == effect), None)


def size_rivals(result: Diagnosis, effect: str, registry: EffectRegistry) -> list[Rival]:
    """An effect whose size is undetermined, at two sizes a standard error either side of its fitted one (each
    key parameter held there, the rest fitted): the experiment that tells them apart determines the size."""
    fitted = last_fit_of(result, effect)
    if fitted is None:
        return []
    prior = hypothetical_size(registry, effect, result.final.fit.model.sensor)
    sizes = {}
    for name in prior:
        error = fitted.stderr.get(name, math.inf)
        sizes[name] = (fitted.values[name], error if math.isfinite(error) and error > 0 else abs(prior[name]))
    effects = [*result.final.effects, effect]
    start = {**result.final.fit.values, **fitted.values}
    best = fitted_rival(effect, effects, result, registry, start)
    for _ in range(SIZE_HALVINGS):
        rivals = []
        for sign, word in ((-1, "smaller"), (1, "larger")):
            held = {name: value + sign * error for name, (value, error) in sizes.items()}
            label = f"{effect} {word} (" + ", ".join(f"{k} = {v:.3g}" for k, v in held.items()) + ")"
            rivals.append(dataclasses.replace(fitted_rival(label, effects, result, registry, start, held),
                                              sized=True))
        if all(r.chi2 - best.chi2 < TOLD_APART_CHI2 for r in rivals):
            return rivals
        sizes = {name: (value, error / 2) for name, (value, error) in sizes.items()}
    return []


def size_z(result: Diagnosis, effect: str, registry: EffectRegistry) -> float:
    """How many standard errors from zero the start holds an undetermined effect's size: the largest over its key
    parameters of |value| / standard error, in the fit ``size_rivals`` offsets by those standard errors (0 when
    none is finite)."""
    fitted = last_fit_of(result, effect)
    if fitted is None:
        return 0.0
    zs = [abs(fitted.values[name]) / error for name in hypothetical_size(registry, effect, fitted.model.sensor)
          if math.isfinite(error := fitted.stderr.get(name, math.inf)) and error > 0]
    return max(zs, default=0.0)


def joined_fit(rival: Rival, question: Sequence[str], joined: Diagnosis, registry: EffectRegistry) -> FitResult:
    """``rival`` refitted (noise-weighted, nothing held but a size that is its hypothesis, ``sized``) to a joined
    campaign together with what that campaign's diagnosis needs beyond the question: the effects of its final model
    the question is not about, and the baseline parameters it found determined. So the rivals differ only by their
    hypotheses, and neither pays for a misfit both share (docs/planning.md, investigate). The better of two starts:
    the rival's values over the joined model's, and the reverse."""
    needs = [name for name in joined.final.effects if name not in question and name not in rival.effects]
    released = frozenset(getattr(rival.model, "released", frozenset())) | frozenset(joined.released)
    model = ReleasedModel(joined.final.fit.model.sensor, [*rival.effects, *needs], registry, released)
    names = {p.name for p in model.parameters()}
    found = joined.final.fit.values
    held = rival.held if rival.sized else None
    fits = [weighted_fit(model, joined.data, joined.evidence_noise, {k: v for k, v in start.items() if k in names},
                         held) for start in ({**rival.values, **found}, {**found, **rival.values})]
    return min(fits, key=lambda fit: chi2_of(fit, joined.evidence_noise))


def nested_rivals(result: Diagnosis, effect: str, registry: EffectRegistry, *, hypothetical: bool) -> list[Rival]:
    """The final model without ``effect`` and with it (fitted, or ``hypothetical``: held at a plausible size)."""
    base = list(result.final.effects)
    without = fitted_rival("without " + effect, base, result, registry, result.final.fit.values)
    held = hypothetical_size(registry, effect, result.final.fit.model.sensor) if hypothetical else {}
    start = {**result.final.fit.values, **effect_start(result, effect), **held}
    with_it = fitted_rival(effect, [*base, effect], result, registry, start, held)
    return [without, with_it] if all(math.isfinite(r.chi2) for r in (without, with_it)) else []
