"""What the diagnosis found: candidates with their checks, the chain of models, the whole result."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ecds_lab.analysis.associations import Association
from ecds_lab.analysis.diagnosis.structure import ResidualStructure
from ecds_lab.analysis.fitting import FitResult
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.analysis.outliers import Outlier
from ecds_lab.analysis.quantities import PositionErrorFigure, chain_position_error, params_json
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import Effect

#: How ``identifiability.absorbed`` says it in an effect's reason for being untestable (``Diagnosis.absorbed``).
ABSORBED_WORDS = "absorbed by the calibration"

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
    #: fall of the held-out sum of squares in noise variances (``held_out.held_out_gain``)
    held_out_gain: float | None = None
    checks: dict[str, bool] = field(default_factory=dict)
    rejected: list[str] = field(default_factory=list)
    not_better: bool = False
    fit_data: Measurements | None = None
    #: Further starts the effect read off the residual (``Effect.starts_from_residual``), for ``_refined``.
    from_residual: list[dict[str, float]] = field(default_factory=list)

    @property
    def rmse_ppm(self) -> float:
        return self.fit.rms_ppm

    @property
    def passes(self) -> bool:
        return bool(self.checks) and all(self.checks.values())

    @property
    def failed(self) -> set[str]:
        """The checks it failed, by name."""
        return {name for name, passed in self.checks.items() if not passed}

    @property
    def effect_object(self) -> Effect:
        return self.fit.model.effect(self.effect)

    def effect_params(self) -> dict[str, Any]:
        own = {p.name for p in self.effect_object.parameters()}
        return {k: v for k, v in fit_params_json(self.fit).items() if k in own}

    def to_json(self) -> dict[str, Any]:
        return {"effect": self.effect, "rmse_ppm": round(self.rmse_ppm, 3), "delta_bic": round(self.delta_bic, 2),
                "delta_bic_signature": rounded(self.delta_bic_signature, 2), "cv_rmse_ppm": rounded(self.cv_rmse_ppm),
                "held_out_gain": rounded(self.held_out_gain, 1), "chi2_gain": round(self.chi2_gain, 1),
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
    #: When the effect added stands for a tied group (the data cannot tell its members apart): the group.
    #: The search goes on with it in the model, but none of the group is claimed.
    stands_for: list[str] = field(default_factory=list)
    #: When the effect added explains only part of a residual the library does not describe: the structure
    #: (standard deviations beyond chance) the final residual keeps where the effect acts. Not claimed.
    leaves_structure: float | None = None
    #: When the final residual drifts in time and the effect keeps less than half its gain once a slow drift is
    #: allowed (``drift.gain_beside_drift``): the share of its gain it keeps. Not claimed.
    part_of_drift: float | None = None
    #: When the effect added was judged beside a flexible nuisance taking a residual outside the library
    #: (``search._beside_smooth``): the variables that nuisance was smooth in. Claimed (unless it stands for a group).
    beside: list[str] = field(default_factory=list)
    #: That nuisance's form: "smooth" (splines) or "straight line" (a drift in time, per frequency).
    beside_form: str = ""
    #: On a screened campaign, the screening subsample and this model refitted there (the claim's refit there from
    #: its candidate's solution, ``search._full_fit_beside_starts``, or from this fit's, ``search._refitted_on``):
    #: what its round's candidates were weighed against.
    on_screen: tuple[Measurements, FitResult] | None = None

    @property
    def rmse_ppm(self) -> float:
        return self.fit.rms_ppm

    def added_from(self, before: Step) -> Candidate:
        """The candidate of ``before``'s round whose effect this step added."""
        return next(c for c in before.candidates if c.effect == self.effects[-1])

    @property
    def claims(self) -> bool:
        """The effect added is claimed: it stands for no tied group, leaves no structure where it acts and is no
        part of a drift in time."""
        return not self.stands_for and self.leaves_structure is None and self.part_of_drift is None

    def position_error(self, noise_ppm: float | None) -> PositionErrorFigure:
        """This model's position error over the readings it can speak for, or why it is no length: "model
        fails here" when its residual is far above the noise, "out of range" without a calibrated reading
        (``quantities.position_error_figure``; the one figure the JSON, the text and the report show)."""
        return chain_position_error(self.residual_mm, self.full_scale_mm, self.rmse_ppm, noise_ppm)

    def to_json(self, noise_ppm: float | None = None) -> dict[str, Any]:
        """The step's figures; ``position_error_mm`` (RMS) and its % FS are None unless the figure is valid."""
        figure = self.position_error(noise_ppm)
        return {"effects": list(self.effects), "rmse_ppm": round(self.rmse_ppm, 3), "bic": round(self.fit.bic, 2),
                **position_error_json(figure),
                "stands_for": list(self.stands_for), "leaves_structure": rounded(self.leaves_structure, 1),
                "part_of_drift": rounded(self.part_of_drift, 2), "beside": list(self.beside),
                "beside_form": self.beside_form,
                "params": fit_params_json(self.fit)}


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
    #: Limits the search reached (e.g. the step cap), in words; with them, the effects left untested.
    limits_reached: list[str] = field(default_factory=list)
    untested: list[str] = field(default_factory=list)
    #: Groups of effects that each explain part of the residual about equally, none of them well: not a
    #: tie between good explanations, so neither claimed nor offered as alternatives.
    partial: list[list[str]] = field(default_factory=list)
    #: Effects with clear evidence whose size these data do not determine (not claimed).
    undetermined: list[str] = field(default_factory=list)
    #: Baseline parameters the rules fix that the data were found to determine (name -> why released).
    released: dict[str, str] = field(default_factory=dict)
    #: The flexible smooth of the final residual (``structure.ResidualStructure``).
    structure: ResidualStructure | None = None
    #: The noise the search judged every candidate's evidence against (found on the start model); ``noise`` is the
    #: one the final model is judged and reported with (``noise.refreshed``). None: the same as ``noise``.
    searched_noise: NoiseEstimate | None = None
    #: At one frequency, where a smooth calibration curve in x takes the final residual's structure: the structure
    #: left after it (the calibration's form, not physics shown to be outside the library); else None.
    calibration_form: ResidualStructure | None = None
    #: Effects that would take the final residual's structure to the noise but that a slow drift in time between the
    #: sweeps explains as well (``search._drift_alike``): that structure is then not shown to lie outside the library.
    drift_alike: list[str] = field(default_factory=list)

    @property
    def evidence_noise(self) -> NoiseEstimate:
        """The noise chi-square gains between candidate models are stated in: the search's (``searched_noise``)."""
        return self.searched_noise if self.searched_noise is not None else self.noise

    @property
    def absorbed(self) -> list[str]:
        """Untestable effects whose signature the calibration absorbs in these data, in ``untestable``'s order."""
        return [name for name, why in self.untestable.items() if ABSORBED_WORDS in why]

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
        """Effects the diagnosis adds to the given model, in the order they were found (not those that
        stand for a tied group: the data cannot tell which of the group it is; nor those that explain only part
        of a residual outside the library)."""
        return [step.effects[-1] for step in self.steps[1:] if step.claims]

    @property
    def searched_with(self) -> list[str]:
        """Every effect in the final model beyond the given ones: the claimed and the tie representatives."""
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
        baseline = first.position_error(self.noise.ppm)
        return {
            "noise_ppm": round(self.noise.ppm, 3),
            "noise_method": self.noise.method,
            "noise": self.noise.to_json(),
            "noise_details": self.noise.details_json(),
            "baseline": {"effects": self.effects, "rmse_ppm": round(first.rmse_ppm, 3),
                         "rmse_mm": rounded(baseline.rms_mm if baseline.valid else None, 5),
                         "position_error_fs_pct": rounded(baseline.fs_percent(baseline.rms_mm)
                                                          if baseline.valid else None, 4),
                         "position_error": baseline.to_json(),
                         "cv_rmse_ppm": rounded(self.baseline_cv_rmse_ppm), "bic": round(first.fit.bic, 2),
                         "params": fit_params_json(first.fit)},
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
            "limits_reached": list(self.limits_reached),
            "untested": list(self.untested),
            "partial": [list(g) for g in self.partial],
            "undetermined": list(self.undetermined),
            "released": dict(self.released),
            "residual_structure": self.structure.to_json() if self.structure is not None else None,
            "calibration_form": self.calibration_form.to_json() if self.calibration_form is not None else None,
            "drift_alike": list(self.drift_alike),
            "steps": [s.to_json(self.noise.ppm) for s in self.steps],
        }


def position_error_json(figure: PositionErrorFigure) -> dict[str, Any]:
    """``position_error_mm`` (RMS), its % FS (both None unless the figure is valid) and the whole figure."""
    rms = figure.rms_mm if figure.valid else None
    return {"position_error_mm": rounded(rms, 5), "position_error_fs_pct": rounded(figure.fs_percent(rms), 4),
            "position_error": figure.to_json()}


def figure_from_json(entry: dict[str, Any]) -> PositionErrorFigure:
    """A position-error figure back from its JSON (``PositionErrorFigure.to_json``), to print it from a report."""
    return PositionErrorFigure(entry["status"], entry["fs_mm"], entry["n"], entry.get("out_of_range", 0),
                               entry.get("max_abs_mm"), entry.get("rms_mm"), entry.get("reason", ""))


def fit_params_json(fit: FitResult) -> dict[str, dict[str, Any]]:
    """A fit's parameters as every JSON output carries them (``quantities.params_json``: value, stderr, unit,
    status, shown), with the ``fixed`` flag of ``FitResult.params_table`` kept for readers of older output."""
    table = fit.params_table()
    return {name: {**row, "fixed": table[name]["fixed"]} for name, row in params_json(fit).items()}


def rounded(value: float | None, digits: int = 3) -> float | None:
    return None if value is None or not math.isfinite(value) else round(value, digits)
