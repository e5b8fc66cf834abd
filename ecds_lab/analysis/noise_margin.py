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

(one estimate serving every bin: B times the F(B, m) distribution's; to first order in 1/m, B + 2B/m and
2B + 2B^2/m, the relative standard error sqrt(2/m) of the estimate entering the spread). The variance is
infinite for m <= 4: such an estimate is counted as ``MIN_DOF``. ``significance`` is the statistic's excess
over that mean in standard deviations of that spread: with the noise known, (statistic - B) / sqrt(2B) as
before, so the thresholds keep their meaning, and a figure that happens to come out low by its own scatter
cannot by itself make a finding. The residual and its noise come from the same readings, which makes the two
positively correlated under pure noise: the spread above is then an upper bound (a margin, not an exact law).
The inverse chi-square's upper tail is heavier than a normal's, so beyond 8 of these standard deviations a
figure of very few dof still leaves a small chance (8 dof: 0.07 %; 30 dof: none in 20,000 draws).
"""

from __future__ import annotations

import math

import numpy as np

#: Fewest degrees of freedom an estimate is counted with (the inverse chi-square's variance is infinite at 4).
MIN_DOF = 5.0


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
    ``loads`` and ``dof``) lies: its excess over the null mean in standard deviations of the null, the noise
    estimates' uncertainty counted (``null_moments``)."""
    if not bins > 0:
        return 0.0
    mean, sd = null_moments(bins, loads, dof)
    return (statistic - mean) / sd if sd > 0 else 0.0
