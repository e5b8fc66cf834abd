"""The margin a chi-square test of means must leave for the noise estimate's own uncertainty.

A test of structure sums, over bins (states of a campaign, bins of one variable), n_b times the squared mean
residual in units of each reading's *estimated* noise. For pure noise of exactly that size the sum is
chi-square with one degree of freedom per bin: mean B, variance 2B. But each noise figure is itself an
estimate: a variance from m effective degrees of freedom (``PhaseNoise.dof``) is off by a relative
sqrt(2/m), and every bin whose readings it serves is off with it, all in the same direction. A reading's
share in an estimate is the part of its noise variance that estimate gives (``NoiseEstimate.variance_shares``:
its phase class's reading noise, the positioning share); a bin's loading on an estimate is the mean share of
its readings, and L_k the loadings summed over the bins. The statistic is then a sum over the estimates of a
chi-square part X_k (mean L_k, variance 2 L_k) times R_k = sigma_k^2 / s_k^2, the true over the estimated
variance: m_k / chi-square(m_k), independent of X_k, with E[R] = m / (m - 2), E[R^2] = m^2 / ((m - 2)(m - 4)).
So the null mean and variance become

    mean = B + sum_k L_k (E[R_k] - 1),
    variance = 2B + sum_k 2 L_k (E[R_k^2] - 1) + sum_k L_k^2 var R_k

(one estimate serving every bin: the F(B, m) distribution's, times B; to first order in 1/m, B + 2B/m and
2B + 2B^2/m). The variance is infinite for m <= 4: such an estimate is counted as ``MIN_DOF`` (its bins can
then hardly show structure). A ratio to an estimated variance has a heavier upper tail than a chi-square
(a figure from 8 readings comes out at a tenth of the truth about once in 10^4), so ``significance`` reads the
statistic's upper tail probability from B times an F(B, nu) distribution scaled to those two moments, and
states it on the known-noise test's own scale: the excess, in standard deviations of chi-square(B), of the
chi-square value with the same tail (with the noise known, exactly (statistic - B) / sqrt(2B), as before).
A statistic judged against a figure from few readings needs more to stand out, and a figure that happens to
come out low by its own scatter cannot by itself make a finding. The residual
and its noise come from the same readings, which makes the two positively correlated under pure noise: the
variance above is then an upper bound (a margin, not an exact law).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import chdtrc, chdtri, fdtrc

#: Fewest degrees of freedom an estimate is counted with (the inverse chi-square's variance is infinite at 4).
MIN_DOF = 5.0
#: Tail probabilities below this are beyond what the quantile functions resolve.
TINY = 1e-280


def loadings(labels: np.ndarray, shares: np.ndarray) -> np.ndarray:
    """L_k: per estimate (a column of ``shares``), its mean share over the readings of each bin (``labels``,
    non-negative integers), summed over the bins."""
    if not len(labels) or not shares.shape[1]:
        return np.zeros(shares.shape[1])
    counts = np.bincount(labels)
    used = counts > 0
    return np.array([float(np.sum(np.bincount(labels, weights=shares[:, k], minlength=len(counts))[used]
                                  / counts[used])) for k in range(shares.shape[1])])


def null_moments(bins: float, loads: np.ndarray, dof: np.ndarray) -> tuple[float, float]:
    """Mean and standard deviation of the bin-means statistic with ``bins`` degrees of freedom for pure noise,
    the noise estimates (``loads`` on each, their ``dof``; inf: known) uncertain as the module docstring says."""
    finite = np.isfinite(dof)
    m = np.maximum(dof[finite], MIN_DOF)
    load = loads[finite]
    ratio = m / (m - 2.0)  # E[R]
    square = m * m / ((m - 2.0) * (m - 4.0))  # E[R^2]
    mean = bins + float(np.sum(load * (ratio - 1.0)))
    variance = 2.0 * bins + float(np.sum(2.0 * load * (square - 1.0) + load**2 * (square - ratio**2)))
    return mean, math.sqrt(max(variance, 0.0))


def significance(statistic: float, bins: float, loads: np.ndarray, dof: np.ndarray) -> float:
    """How far beyond chance the bin-means ``statistic`` (``bins`` degrees of freedom, the noise estimates'
    ``loads`` and ``dof``) lies, on the known-noise test's scale (see the module docstring): the upper tail
    probability under a scaled F matched to ``null_moments``, as the chi-square(bins) excess with that tail
    in its standard deviations. Beyond the tails double precision holds, the moments' own standardised excess."""
    if not bins > 0:
        return 0.0
    mean, sd = null_moments(bins, loads, dof)
    spread = sd * sd * bins / (2.0 * mean * mean)  # 1 for a chi-square(bins) scaled to its mean
    if spread <= 1.0 + 1e-9:
        tail = float(chdtrc(bins, statistic * bins / mean))
    else:
        nu = (bins - 2.0 + 4.0 * spread) / (spread - 1.0)
        tail = float(fdtrc(bins, nu, max(statistic, 0.0) / (mean * (nu - 2.0) / nu)))
    if not TINY < tail < 1.0:
        return (statistic - mean) / sd
    return (float(chdtri(bins, tail)) - bins) / math.sqrt(2.0 * bins)
