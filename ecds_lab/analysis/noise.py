"""How noisy are the data? Estimated from the data themselves, so structure can be told from noise.

The one noise estimator: every fit carries its estimate (``FitResult.noise``), so ``fit``,
``diagnose`` and the report quote the same figure for the same data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ecds_lab.data.measurements import Measurements

#: Successive readings of one state: at most this far apart in time, and this close in temperature.
MAX_GAP_S = 300.0
MAX_TEMPERATURE_STEP_K = 0.3
MIN_PAIRS = 20
#: ``NoiseEstimate.method`` when repeated readings of one state gave the estimate.
REPEATED = "repeated readings"


@dataclass(frozen=True)
class NoiseEstimate:
    """Noise of one reading in ppm of L, how it was found, and from how many pairs."""

    ppm: float
    method: str
    pairs: int


def _robust_sigma(differences: np.ndarray) -> float:
    """Standard deviation of one reading from differences of two: 1.4826 MAD / sqrt(2)."""
    mad = np.median(np.abs(differences - np.median(differences)))
    return float(1.4826 * mad / math.sqrt(2))


def estimate_noise(data: Measurements, residuals_ppm: np.ndarray) -> NoiseEstimate:
    """Repeatability from pairs of successive readings of one state (same recording, frequency,
    distance and direction, close in time and temperature), using model residuals so slow
    changes the model already explains do not count as noise. Without enough repeats, the
    successive differences of the residual in time order (per recording and frequency).
    """
    order = np.lexsort((data.time_s, data.direction, data.x_commanded_m, data.freq_hz, data.segment))
    r = residuals_ppm[order]
    keys = [a[order] for a in (data.segment, data.freq_hz, data.x_commanded_m, data.direction)]
    same = np.ones(len(r) - 1, bool) if len(r) > 1 else np.zeros(0, bool)
    for key in keys:
        same &= key[1:] == key[:-1]
    t, tc, tt = (a[order] for a in (data.time_s, data.t_coil_c, data.t_target_c))
    same &= np.abs(np.diff(t)) <= MAX_GAP_S
    same &= (np.abs(np.diff(tc)) <= MAX_TEMPERATURE_STEP_K) & (np.abs(np.diff(tt)) <= MAX_TEMPERATURE_STEP_K)
    if same.sum() >= MIN_PAIRS:
        return NoiseEstimate(_robust_sigma(np.diff(r)[same]), REPEATED, int(same.sum()))
    order = np.lexsort((data.time_s, data.freq_hz, data.segment))
    r, seg, freq = residuals_ppm[order], data.segment[order], data.freq_hz[order]
    same = (seg[1:] == seg[:-1]) & (freq[1:] == freq[:-1])
    if same.sum() < 3:
        return NoiseEstimate(float(np.std(residuals_ppm)), "residual spread (too few readings)", 0)
    return NoiseEstimate(_robust_sigma(np.diff(r)[same]), "successive differences of the residual",
                         int(same.sum()))
