"""The verdict: adequate, missing_effect or inconclusive, from the chain of models and the residual."""

from __future__ import annotations

import math
from collections.abc import Sequence

from ecds_lab.analysis.associations import Association
from ecds_lab.analysis.diagnosis.result import Step
from ecds_lab.analysis.diagnosis.structure import ResidualStructure
from ecds_lab.analysis.noise import NoiseEstimate

#: The residual is "at the noise level" below this multiple of the noise (the search refines candidates above it).
ADEQUATE_RATIO = 1.2
#: A residual above this multiple of the noise is clearly above it (said so in the explanation); whether it
#: lies outside the library is decided by its structure (``outside_library``), not by its size alone.
FAILING_RATIO = 1.5
#: Residual structure this many standard deviations beyond chance (for pure noise of the estimated
#: size) marks a missing effect once the residual is at least a little above the noise.
STRUCTURE_SIGNIFICANCE = 8.0
STRUCTURE_RATIO = 1.03


def outside_library(final: Step, noise: NoiseEstimate, structure: ResidualStructure,
                    associations: Sequence[Association] = ()) -> bool:
    """The final residual holds what the library does not explain: a flexible smooth of it finds structure
    STRUCTURE_SIGNIFICANCE standard deviations beyond chance (the smooth over every state, or the bin means
    over one variable: x, a temperature, time within a phase, which see a trend the many states dilute),
    and it is at least a little above the noise: each reading judged against its own noise
    (``ResidualStructure.noise_ratio``), since the noise differs between phases (a hold in air read at 15 ppm
    beside sweeps at 40 ppm: a residual twice the noise in the hold and half of it in the sweeps is, in one
    pooled RMS, below the pooled noise)."""
    smooth = structure.beyond(STRUCTURE_SIGNIFICANCE) or any(a.significance > STRUCTURE_SIGNIFICANCE
                                                              for a in associations)
    return smooth and judged_ratio(final, noise, structure) > STRUCTURE_RATIO


def judged_ratio(final: Step, noise: NoiseEstimate, structure: ResidualStructure) -> float:
    """The residual's size in units of the noise as the verdict judges it: against each reading's own noise where
    the structure's smooth measured it, else the RMS against the pooled noise (``noise_ratio``)."""
    return structure.noise_ratio if math.isfinite(structure.noise_ratio) else noise_ratio(final, noise)


def noise_ratio(step: Step, noise: NoiseEstimate) -> float:
    """The step's residual RMS in multiples of the noise."""
    return step.rmse_ppm / noise.ppm if noise.ppm > 0 else math.inf


def verdict_of(steps: list[Step], effects: list[str], noise: NoiseEstimate, structure: ResidualStructure,
               alternatives: list[list[str]], untestable: dict[str, str], limits: list[str],
               associations: Sequence[Association] = (), calibration_form: bool = False,
               drift_alike: bool = False) -> str:
    """missing_effect when effects were claimed, or when every candidate was refitted at the final model
    and the residual still holds structure (outside the library; a tie beside it is listed, not the verdict);
    inconclusive when the data cannot separate the candidates and nothing lies outside the library, could test none
    of them, the search stopped at a limit first, the residual is
    clearly above the noise without structure a model could take (scatter the noise estimate misses), or its
    structure is one a smooth calibration curve in x takes (``calibration_form``, at one frequency) or a library
    effect takes that a slow drift in time explains as well (``drift_alike``)."""
    if any(step.claims for step in steps[1:]):
        return "missing_effect"
    outside = outside_library(steps[-1], noise, structure, associations)
    explained = calibration_form or drift_alike  # the structure is taken by something other than missing physics
    if alternatives:
        return "missing_effect" if outside and not limits and not explained else "inconclusive"
    if not outside:
        # Above the noise without structure: scatter the noise estimate misses (e.g. between moves), not adequate.
        return "adequate" if noise_ratio(steps[-1], noise) <= FAILING_RATIO else "inconclusive"
    return "missing_effect" if steps[0].candidates and not limits and not explained else "inconclusive"
