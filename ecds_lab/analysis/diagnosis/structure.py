"""Is there structure in a residual beyond chance? A flexible smooth of it, judged against the noise.

The smooth is the residual's mean in each *state* of the campaign: one phase (``analysis.phases``),
frequency, direction, commanded distance (or the coil in air), target and coil temperature in bins of
``TEMPERATURE_BIN_K`` and a stretch of ``TIME_BIN_S`` of time within the phase. Whatever any smooth
function of x, the temperatures and time within a phase would follow, these means follow as well; what
they cannot follow is the scatter between readings of one state. For pure noise of the estimated size
their energy (sum over states of count x mean^2, in noise variances) is chi-square with one degree of
freedom per state, were the noise known exactly. It is estimated, each phase class's figure from its own
effective degrees of freedom, so the null mean and spread are widened by that estimate's own uncertainty
(``analysis.noise_margin``): how far beyond chance the energy lies with that uncertainty counted, on the
known-noise test's scale (chi-square standard deviations), is the ``significance``, and a noise figure
estimated from few readings cannot by itself make structure.
Readings are weighed by their own noise (``NoiseEstimate.sigma_ppm``) and the energy divided by the
design effect (``NoiseEstimate.design_effect``: correlated readings count as fewer independent ones).
The residual's size is judged the same way (``noise_ratio``: its RMS in units of each reading's own noise), so a
residual above the noise where the noise is small is not hidden by readings far below a larger noise elsewhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.analysis.noise_margin import loadings, null_moments, significance
from ecds_lab.analysis.per_readings import per_readings
from ecds_lab.analysis.phases import phase_labels
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.row_labels import row_labels

#: Temperature bins (K) and time bins within a phase (s) of one state.
TEMPERATURE_BIN_K = 2.0
TIME_BIN_S = 1800.0


@dataclass(frozen=True)
class ResidualStructure:
    """What a flexible smooth finds in a residual: its energy beyond chance (``excess_chi2``, in noise
    variances, design effect applied, over the null mean with the noise estimate's uncertainty), the states it
    used and how far beyond chance that is, that uncertainty counted (``noise_margin.significance``: on the
    known-noise test's scale, standard deviations of a chi-square with one degree of freedom per state);
    ``margin``: the factor by which the noise estimate's uncertainty widened the null's spread; and the residual's
    RMS in units of each reading's own noise (``noise_ratio``, 1 for a residual that is noise of the estimated
    size)."""

    excess_chi2: float
    states: int
    significance: float
    noise_ratio: float = math.nan
    margin: float = 1.0

    def beyond(self, sigmas: float) -> bool:
        return self.significance > sigmas

    def to_json(self) -> dict[str, float | int | None]:
        ratio = round(self.noise_ratio, 3) if math.isfinite(self.noise_ratio) else None
        return {"excess_chi2": round(self.excess_chi2, 1), "states": self.states,
                "significance": round(self.significance, 2), "noise_ratio": ratio, "margin": round(self.margin, 3)}


@per_readings
def state_labels(data: Measurements) -> np.ndarray:
    """State number of every reading (see the module docstring); computed once per campaign (``per_readings``)."""
    phases = phase_labels(data)
    x = np.where(np.isfinite(data.x_commanded_m), np.round(data.x_commanded_m, 6), -1.0)
    start = np.zeros(len(data))
    for phase in np.unique(phases):
        rows = phases == phase
        start[rows] = data.time_s[rows].min()
    columns = [phases, data.freq_hz, data.direction, x, np.floor(data.t_target_c / TEMPERATURE_BIN_K),
               np.floor(data.t_coil_c / TEMPERATURE_BIN_K), np.floor((data.time_s - start) / TIME_BIN_S)]
    return row_labels(*columns)


def residual_structure(data: Measurements, residuals_ppm: np.ndarray, noise: NoiseEstimate,
                       rows: np.ndarray | None = None) -> ResidualStructure:
    """The flexible smooth's energy beyond chance (see the module docstring); over ``rows`` only if given
    (a boolean mask: the states are those of the whole campaign)."""
    if not len(data) or not noise.ppm > 0:
        return ResidualStructure(0.0, 0, 0.0, 0.0)
    whitened = np.asarray(residuals_ppm, float) / noise.sigma_ppm(data)
    labels = state_labels(data)
    shares, dof = noise.variance_shares(data)
    if rows is not None:
        whitened, labels, shares = whitened[rows], labels[rows], shares[rows]
        if not len(labels):
            return ResidualStructure(0.0, 0, 0.0, 0.0)
    counts = np.bincount(labels)
    sums = np.bincount(labels, weights=whitened)
    energy = float(np.sum(sums[counts > 0] ** 2 / counts[counts > 0])) / noise.design_effect
    states = int((counts > 0).sum())
    loads = loadings(labels, shares)
    mean, sd = null_moments(states, loads, dof)
    ratio = float(np.sqrt(np.mean(whitened**2)))
    return ResidualStructure(max(energy - mean, 0.0), states, significance(energy, states, loads, dof), ratio,
                             sd / math.sqrt(2.0 * states))
