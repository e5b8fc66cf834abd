"""The competing models of an open question, each fitted to the campaign: the chain's model and its alternatives.

A tie: the diagnosis's final model with the effect that stands for the group swapped for each member. An effect
with evidence but undetermined size, or one the data cannot test yet: the final model without it and with it;
an untestable effect has no fitted size, so it enters at a plausible one (``hypothetical_size``) held fixed while
the model is fitted to the campaign (its calibration then takes what the data cannot tell from it). An effect with
clear evidence and an undetermined size is present; the question is its size: the rivals are the effect a standard
error either side of its fitted size (``size_rivals``). A held parameter is part of a rival's hypothesis and stays
held when the rival is refitted to a candidate's predicted readings.

Every fit here weighs each reading by its own noise (``NoiseEstimate.sigma_ppm``) and counts chi-square in noise
variances over the readings' design effect, as the diagnosis's evidence does (docs/diagnosis.md).
"""

from __future__ import annotations

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

    def predict(self, data: Measurements) -> np.ndarray:
        """Ls (H) this model predicts for ``data``."""
        return self.model.predict(data, self.values)

    def to_json(self) -> dict[str, object]:
        return {"label": self.label, "effects": list(self.effects), "chi2": round(self.chi2, 1),
                "held": {k: float(f"{v:.4g}") for k, v in self.held.items()}}


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
    fit = weighted_fit(model, result.data, result.noise, start, held)
    return Rival(label, tuple(effects), model, fit.values, chi2_of(fit, result.noise), dict(held or {}))


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
    parameters = cls(sensor).parameters()
    keys = cls.key_parameters or tuple(p.name for p in parameters)
    return {p.name: (p.value if p.value != 0 else p.prior_scale) for p in parameters if p.name in keys}


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


def size_rivals(result: Diagnosis, effect: str, registry: EffectRegistry) -> list[Rival]:
    """An effect whose size is undetermined, at two sizes a standard error either side of its fitted one (each
    key parameter held there, the rest fitted): the experiment that tells them apart determines the size."""
    fitted = next((c.fit for step in reversed(result.steps) for c in step.candidates if c.effect == effect), None)
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
            rivals.append(fitted_rival(label, effects, result, registry, start, held))
        if all(r.chi2 - best.chi2 < TOLD_APART_CHI2 for r in rivals):
            return rivals
        sizes = {name: (value, error / 2) for name, (value, error) in sizes.items()}
    return []


def joined_fit(rival: Rival, question: Sequence[str], joined: Diagnosis, registry: EffectRegistry) -> FitResult:
    """``rival`` refitted (noise-weighted, nothing held) to a joined campaign together with what that campaign's
    diagnosis needs beyond the question: the effects of its final model the question is not about, and the
    baseline parameters it found determined. So the rivals differ only by their hypotheses, and neither pays for
    a misfit both share (docs/planning.md, investigate). The better of two starts: the rival's values over the
    joined model's, and the reverse."""
    needs = [name for name in joined.final.effects if name not in question and name not in rival.effects]
    released = frozenset(getattr(rival.model, "released", frozenset())) | frozenset(joined.released)
    model = ReleasedModel(joined.final.fit.model.sensor, [*rival.effects, *needs], registry, released)
    names = {p.name for p in model.parameters()}
    found = joined.final.fit.values
    fits = [weighted_fit(model, joined.data, joined.noise, {k: v for k, v in start.items() if k in names})
            for start in ({**rival.values, **found}, {**found, **rival.values})]
    return min(fits, key=lambda fit: chi2_of(fit, joined.noise))


def nested_rivals(result: Diagnosis, effect: str, registry: EffectRegistry, *, hypothetical: bool) -> list[Rival]:
    """The final model without ``effect`` and with it (fitted, or ``hypothetical``: held at a plausible size)."""
    base = list(result.final.effects)
    without = fitted_rival("without " + effect, base, result, registry, result.final.fit.values)
    held = hypothetical_size(registry, effect, result.final.fit.model.sensor) if hypothetical else {}
    start = {**result.final.fit.values, **effect_start(result, effect), **held}
    with_it = fitted_rival(effect, [*base, effect], result, registry, start, held)
    return [without, with_it] if all(math.isfinite(r.chi2) for r in (without, with_it)) else []
