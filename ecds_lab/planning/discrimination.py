"""How well a candidate experiment separates rival models: the T-criterion of Atkinson & Fedorov (1975).

Suppose model A is true. The candidate's readings are then A's predictions (noise-free: the expected value). The
rival B, refitted to the campaign *and* those readings (the minimum over B's parameters, so B's parameter
uncertainty is spent in B's favour; a parameter B's hypothesis holds stays held), leaves a chi-square; the expected
Delta chi-square the joined campaign will show between B and A is that chi-square less A's on the campaign (A fits
its own predictions exactly). Chi-square is counted in the diagnosis's noise model (``NoiseEstimate.sigma_ppm``, per
reading, over the design effect), so the figure compares directly with the diagnosis's evidence threshold (25 noise
variances). Divided by the candidate's lab hours it is the discrimination per hour.

A separation counts only what survives what the models leave out: one reading off (``robust_chi2``) and a smooth
change of the new run's calibration (``calibration_chi2``, ``calibration_change``). For a tie both orders are
computed and the smaller is the candidate's guaranteed separation. For a nested question (an effect present or not)
only "present at its size" is computed: the model without it cannot be told from the model with it at size zero by
any experiment; what an experiment can do is show it if it is there.

The truth's parameter uncertainty: where the campaign leaves a shape parameter of the truth flat (``Rival.plausible``:
the truth across its profile interval), each figure is the least over the truth at its fit and at every point
of it (a minimax over the values the data allow, as Atkinson & Fedorov's T-optimality does over unknown parameters), the
figures at the fit kept beside (``Separation.at_fit``). The rival's own uncertainty is already spent in its favour
by the refit.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ecds_lab.analysis.diagnosis import Diagnosis
from ecds_lab.analysis.fitting import FitResult
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.planning.calibration_change import absorbed_fit
from ecds_lab.planning.rivals import Rival, chi2_of, joined_fit, weighted_fit, with_plausible

#: Delta chi-square (noise variances) that decides: the diagnosis's evidence threshold (docs/diagnosis.md).
DECISIVE_CHI2 = 25.0


@dataclass(frozen=True)
class Separation:
    """If ``truth`` holds, the Delta chi-square ``rival`` will show on the joined campaign (and what the candidate
    adds to the rival's chi-square: the T-criterion proper)."""

    truth: str
    rival: str
    delta_chi2: float
    added_chi2: float
    #: ``delta_chi2`` without the planned reading that adds most: a decision must not hinge on one reading (a
    #: glitch there would fake it)
    robust_chi2: float
    #: what the planned readings add to the rival's chi-square when the rival may also change the new run's
    #: calibration smoothly (``calibration_change``): a decision must not rest on what a drift could fake
    calibration_chi2: float
    #: the same at the truth's fitted values alone, when the truth has a plausible range (``Rival.plausible``) and
    #: the figures above are the least over it
    at_fit: Separation | None = None

    @property
    def guaranteed(self) -> float:
        """The separation that survives both: one reading off (a glitch) and a smooth calibration change."""
        return min(self.robust_chi2, self.calibration_chi2)

    def to_json(self) -> dict[str, object]:
        out: dict[str, object] = {"truth": self.truth, "rival": self.rival, "delta_chi2": round(self.delta_chi2, 1),
                                  "added_chi2": round(self.added_chi2, 1), "robust_chi2": round(self.robust_chi2, 1),
                                  "calibration_chi2": round(self.calibration_chi2, 1)}
        if self.at_fit is not None:
            point = self.at_fit.to_json()
            out["at_fit"] = {k: point[k] for k in ("delta_chi2", "added_chi2", "robust_chi2", "calibration_chi2")}
        return out


def predicted_readings(truth: Rival, planned: Measurements) -> Measurements:
    """The planned readings as ``truth`` predicts them (the expected readings, no noise)."""
    return dataclasses.replace(planned, ls_h=truth.predict(planned))


def separation(truth: Rival, rival: Rival, campaign: Measurements, planned: Measurements,
               noise: NoiseEstimate) -> Separation:
    """The T-criterion of ``rival`` against ``truth`` for the planned readings, each figure the least over the
    truth's plausible values (module docstring), the figures at its fit kept as ``at_fit``."""
    point = point_separation(truth, rival, campaign, planned, noise)
    if not truth.plausible:
        return point
    every = [point, *(point_separation(t, rival, campaign, planned, noise) for t in truth.plausible)]
    return Separation(truth.label, rival.label, min(s.delta_chi2 for s in every), min(s.added_chi2 for s in every),
                      min(s.robust_chi2 for s in every), min(s.calibration_chi2 for s in every), point)


def point_separation(truth: Rival, rival: Rival, campaign: Measurements, planned: Measurements,
                     noise: NoiseEstimate) -> Separation:
    """The T-criterion of ``rival`` against ``truth`` at the truth's values (module docstring)."""
    readings = predicted_readings(truth, planned)
    joined = Measurements.concatenate([campaign, readings])
    refit = weighted_fit(rival.model, joined, noise, rival.values, rival.held)
    chi2 = chi2_of(refit, noise)
    new = refit.effective_residuals_ppm[len(campaign):] / noise.ppm
    largest = float(np.max(new**2)) / max(noise.design_effect, 1.0) if len(new) else 0.0
    absorbed = chi2_of(absorbed_fit(rival, campaign, readings, refit, noise), noise)
    return Separation(truth.label, rival.label, chi2 - truth.chi2, chi2 - rival.chi2, chi2 - truth.chi2 - largest,
                      absorbed - rival.chi2)


def question_separations(kind: str, rivals: list[Rival], campaign: Measurements, planned: Measurements,
                         noise: NoiseEstimate) -> list[Separation]:
    """Every separation a question needs: each ordered pair for a tie or two sizes; "present" against "absent"
    when nested (``rivals`` then [without, with])."""
    if kind in ("tie", "undetermined"):
        return [separation(a, b, campaign, planned, noise) for a in rivals for b in rivals if a is not b]
    without, with_it = rivals
    return [separation(with_it, without, campaign, planned, noise)]


def decisive(separations: list[Separation]) -> float:
    """The separation the candidate guarantees: the least over the truths it must tell apart, each without its
    most telling reading and after a smooth calibration change of the run (``Separation.guaranteed``)."""
    return min((s.guaranteed for s in separations), default=0.0)


def expected(separations: list[Separation], truth: str, *, at_fit: bool = False) -> float | None:
    """The Delta chi-square predicted if ``truth`` holds (all planned readings; the least over its plausible values,
    or ``at_fit`` at its fitted values alone), None if not among them."""
    found = next((s for s in separations if s.truth == truth), None)
    if found is None:
        return None
    return (found.at_fit or found).delta_chi2 if at_fit else found.delta_chi2


def measured_fits(rivals: list[Rival], campaign: Measurements, noise: NoiseEstimate) -> dict[str, FitResult]:
    """Each rival alone refitted (noise-weighted, nothing held but a size that is the hypothesis, ``Rival.sized``)
    to the joined campaign: label -> its fit. Kept
    beside ``joined_fits``: where the joined campaign needs an effect neither rival holds, both pay for it and
    their difference measures that shared misfit more than the question (docs/planning.md, investigate)."""
    return {r.label: weighted_fit(r.model, campaign, noise, r.values, r.held if r.sized else None) for r in rivals}


def joined_fits(rivals: list[Rival], question: Sequence[str], joined: Diagnosis,
                registry: EffectRegistry) -> dict[str, FitResult]:
    """Each rival refitted to the joined campaign with what its diagnosis needs beyond the ``question``'s effects
    (``rivals.joined_fit``): label -> its fit. The measured separation is the difference of their chi-squares."""
    return {r.label: joined_fit(r, question, joined, registry) for r in rivals}


def measured_separation(fits: Mapping[str, FitResult], noise: NoiseEstimate) -> tuple[str, float, dict[str, float]]:
    """The rival that fits best, its lead over the next (noise variances) and every rival's chi-square."""
    chi2 = {label: chi2_of(fit, noise) for label, fit in fits.items()}
    ordered = sorted(chi2.values())
    winner = min(chi2, key=chi2.__getitem__)
    return winner, (ordered[1] if len(ordered) > 1 else ordered[0]) - ordered[0], chi2


def at_measured_size(truth: Rival, rival: Rival, measured: Mapping[str, float], campaign: Measurements,
                     planned: Measurements, noise: NoiseEstimate) -> float | None:
    """The Delta chi-square predicted had ``truth`` held its hypothetical size at the size the joined campaign
    measured (``measured``: the truth's free refit there), else None (nothing held: no size was supposed).

    A nested question's rival enters at a plausible size (``rivals.hypothetical_size``), and its separation grows
    like the square of that size: a prediction at a supposed size cannot be checked against a truth of another
    size. This is the same T-criterion with the size the run found, the figure a measured separation is compared
    with; the prediction at the hypothetical size stays the one the choice was made on."""
    return _at_measured(truth, rival, measured, list(truth.held), campaign, planned, noise)


def at_measured_values(truth: Rival, rival: Rival, measured: Mapping[str, float], campaign: Measurements,
                       planned: Measurements, noise: NoiseEstimate, *, at_fit: bool = False) -> float | None:
    """``at_measured_size`` for every value the prediction supposed rather than measured: the truth's held size,
    and the parameters the campaign cannot determine, which the model's rules hold at a default (tau_T at one
    frequency, where Ls ties it to the coupling's gain exactly; C_p there). Such a default is a supposition like
    a hypothetical size: the campaign fits as well at any value, and the separation at a new frequency depends on
    it. The truth's fitted parameters stay the campaign's estimates, a shape parameter the campaign leaves flat
    taken over its plausible range again with the supposed values held (``at_fit``: at its fit alone). None if it
    supposed nothing (docs/planning.md, investigate)."""
    supposed = [*truth.held, *truth.model.unidentifiable(campaign)]
    return _at_measured(truth, rival, measured, supposed, campaign, planned, noise, at_fit=at_fit)


def _at_measured(truth: Rival, rival: Rival, measured: Mapping[str, float], supposed: Sequence[str],
                 campaign: Measurements, planned: Measurements, noise: NoiseEstimate, *, at_fit: bool = False
                 ) -> float | None:
    """The T-criterion with ``truth``'s ``supposed`` parameters held at the ``measured`` values, the rest refitted
    to the campaign (the least over the plausible values that leaves, or ``at_fit`` at the refit alone); None if
    nothing was supposed."""
    held = {name: measured[name] for name in supposed if name in measured}
    if not held:
        return None
    fit = weighted_fit(truth.model, campaign, noise, {**truth.values, **held}, held)
    sized = dataclasses.replace(truth, values=fit.values, chi2=chi2_of(fit, noise), held=held, plausible=())
    if not at_fit:
        sized = with_plausible(sized, campaign, noise)
    return separation(sized, rival, campaign, planned, noise).delta_chi2
