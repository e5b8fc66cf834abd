"""How noisy are the data? Estimated from the data themselves, so structure can be told from noise.

One estimator for the whole analysis (fit and diagnosis report the same noise):

1. Repeats: pairs of successive readings of one state (same recording, frequency, distance and
   direction, close in time and temperature). Their difference holds only the bridge's noise.
2. Without enough repeats: the residual minus a flexible smooth of itself (a local quadratic over
   ``NOISE_WINDOW`` successive readings of one run of like readings, ``reading_groups``: a
   Savitzky-Golay filter), scaled robustly (MAD). The smooth follows slopes and bends of the
   residual (structure the model leaves), so structure cannot inflate the estimate the way
   successive differences do, and the MAD keeps single glitches from inflating it either.

Beside the bridge's reading noise, a station may declare its slide's positioning repeatability
(1 sigma, from the slide's datasheet; ``Measurements.slide_repeatability_m``). Each move lands a
little off the commanded distance at random, and the reading follows: sigma_x |d ln L / dx| in ppm.
The data cannot tell this scatter from structure (each position is visited once per direction),
so it is a declared (GUM type-B) figure, counted with the fitted model's sensitivity
(``positioning_noise``), never estimated from the residual. ``NoiseEstimate.ppm`` combines both.

``smooth_residual`` (a running median) is the reference glitches are judged against
(``analysis.outliers``): a median is not pulled toward a glitch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.ndimage import median_filter

from ecds_lab.data.measurements import Measurements

#: Successive readings of one state: at most this far apart in time, and this close in temperature.
#: ``NoiseEstimate.method`` when repeated readings of one state gave the estimate.
REPEATED = "repeated readings"
MAX_GAP_S = 300.0
MAX_TEMPERATURE_STEP_K = 0.3
MIN_PAIRS = 20
#: Readings in the running median glitches are judged against (odd).
SMOOTH_WINDOW = 5
#: Readings in the local quadratic of the noise estimate (odd); for white Gaussian noise of unit sigma
#: the residual about it has sigma sqrt(1 - 1/3) = 0.8165 (the centre weight of a 7-point quadratic is
#: 1/3; Monte Carlo, 1e6 samples: 0.817): the estimate is divided by it.
NOISE_WINDOW = 7
NOISE_SMOOTH_FACTOR = 0.8165
MIN_SMOOTH_READINGS = 12


@dataclass(frozen=True)
class NoiseEstimate:
    """Noise of one reading in ppm of L: the bridge's reading noise (how it was found, from how many
    pairs or readings) and the declared positioning repeatability's share (0 when none is declared)."""

    reading_ppm: float
    method: str
    pairs: int
    positioning_ppm: float = 0.0
    #: How many correlated readings count as one independent one (>= 1): readings of one visit share its
    #: position error, readings of one thermal state share it too. Chi-square and BIC gains are divided by it.
    design_effect: float = 1.0

    def sigma_ppm(self, data: Measurements) -> np.ndarray:
        """The noise of each reading of ``data`` (ppm of L), in its order; uniform here, the same ``ppm``
        for every reading. Residuals divided by it (times ``ppm``) weigh every reading by its own noise."""
        return np.full(len(data), self.ppm)

    @property
    def ppm(self) -> float:
        """The noise models are judged against: reading and positioning parts in quadrature."""
        return math.hypot(self.reading_ppm, self.positioning_ppm)

    @property
    def source(self) -> str:
        """Where the noise comes from, in words: the reading part's method, and the declared positioning part."""
        return noise_parts_text(self.to_json()) or self.method

    def to_json(self) -> dict[str, float | str]:
        return {"reading_ppm": round(self.reading_ppm, 3), "positioning_ppm": round(self.positioning_ppm, 3),
                "method": self.method}


def noise_parts_text(parts: Mapping[str, Any]) -> str:
    """The noise's two parts in words, from ``NoiseEstimate.to_json()`` (as the JSON reports carry it);
    empty when no slide repeatability was declared (the noise is then the reading noise alone)."""
    if not parts.get("positioning_ppm"):
        return ""
    return (f"reading {parts['reading_ppm']:.1f} ppm from {parts['method']}, slide positioning "
            f"{parts['positioning_ppm']:.1f} ppm from the declared repeatability")


def _robust_sigma(differences: np.ndarray) -> float:
    """Standard deviation of one reading from differences of two: 1.4826 MAD / sqrt(2)."""
    mad = np.median(np.abs(differences - np.median(differences)))
    return float(1.4826 * mad / math.sqrt(2))


def reading_groups(data: Measurements) -> list[np.ndarray]:
    """Row indices of each run of like readings in time order: one recording, one frequency, the coil
    in air or facing the target, one direction of approach, no long pause (a smooth runs along each;
    a sweep's turning points are ends of runs, so a peak of the residual there is not cut off)."""
    key = np.lexsort((data.time_s, data.in_air, data.freq_hz, data.segment))
    seg, freq, air, direction, t = (a[key] for a in (data.segment, data.freq_hz, data.in_air, data.direction,
                                                      data.time_s))
    breaks = np.flatnonzero((seg[1:] != seg[:-1]) | (freq[1:] != freq[:-1]) | (air[1:] != air[:-1])
                            | (direction[1:] != direction[:-1]) | (np.diff(t) > MAX_GAP_S)) + 1
    return np.split(key, breaks)


def smooth_residual(data: Measurements, residuals_ppm: np.ndarray, window: int = SMOOTH_WINDOW) -> np.ndarray:
    """Running median of the residual along each series of like readings (``reading_groups``)."""
    r = np.asarray(residuals_ppm, float)
    out = r.copy()
    for rows in reading_groups(data):
        if len(rows) >= 3:
            out[rows] = median_filter(r[rows], size=min(window, len(rows) - (1 - len(rows) % 2)), mode="nearest")
    return out


def _repeat_pairs(data: Measurements, residuals_ppm: np.ndarray) -> np.ndarray:
    """Differences of successive residuals of one state (see the module docstring)."""
    order = np.lexsort((data.time_s, data.direction, data.x_commanded_m, data.freq_hz, data.segment))
    r = residuals_ppm[order]
    if len(r) < 2:
        return np.zeros(0)
    same = np.ones(len(r) - 1, bool)
    for key in (data.segment, data.freq_hz, data.x_commanded_m, data.direction):
        k = key[order]
        same &= (k[1:] == k[:-1]) | (np.isinf(k[1:]) & np.isinf(k[:-1])) if k.dtype.kind == "f" else k[1:] == k[:-1]
    t, tc, tt = (a[order] for a in (data.time_s, data.t_coil_c, data.t_target_c))
    same &= np.abs(np.diff(t)) <= MAX_GAP_S
    same &= (np.abs(np.diff(tc)) <= MAX_TEMPERATURE_STEP_K) & (np.abs(np.diff(tt)) <= MAX_TEMPERATURE_STEP_K)
    return np.diff(r)[same]


def positioning_noise(data: Measurements, relative_sensitivity_per_m: np.ndarray | None) -> float:
    """RMS over all readings of sigma_x |d ln L / dx| (ppm): the declared slide repeatability seen
    through the model's sensitivity; readings in air, or without a declared figure, count 0."""
    sigma = np.nan_to_num(np.asarray(data.slide_repeatability_m, float), nan=0.0, posinf=0.0)
    if relative_sensitivity_per_m is None or not len(sigma) or not (sigma > 0).any():
        return 0.0
    with np.errstate(invalid="ignore"):
        share = np.abs(np.asarray(relative_sensitivity_per_m, float)) * sigma * 1e6
    share = np.where(np.isfinite(data.x_m) & np.isfinite(share), share, 0.0)
    return float(np.sqrt(np.mean(share**2)))


def estimate_noise(data: Measurements, residuals_ppm: np.ndarray,
                   relative_sensitivity_per_m: np.ndarray | None = None) -> NoiseEstimate:
    """Noise of one reading (ppm of L): the reading noise from repeats where they exist, else from the
    residual about a flexible smooth of itself (see the module docstring); ``residuals_ppm`` are model
    residuals, so slow changes the model already explains do not count as noise either way. With the
    model's d ln L / dx per reading (``relative_sensitivity_per_m``), the declared slide repeatability
    is added (``positioning_noise``)."""
    reading = _reading_noise(data, np.asarray(residuals_ppm, float))
    return replace(reading, positioning_ppm=positioning_noise(data, relative_sensitivity_per_m))


def _reading_noise(data: Measurements, r: np.ndarray) -> NoiseEstimate:
    """The bridge's reading noise alone (see ``estimate_noise``)."""
    pairs = _repeat_pairs(data, r)
    if len(pairs) >= MIN_PAIRS:
        return NoiseEstimate(_robust_sigma(pairs), REPEATED, len(pairs))
    usable = [rows for rows in reading_groups(data) if len(rows) >= NOISE_WINDOW]
    count = sum(len(rows) for rows in usable)
    if count < MIN_SMOOTH_READINGS:
        spread = float(1.4826 * np.median(np.abs(r - np.median(r)))) if len(r) else math.nan
        return NoiseEstimate(spread, "robust spread of the residual (too few readings)", len(r))
    from scipy.signal import savgol_filter  # here, not at the top: scipy.signal (and scipy.stats with it) costs
    # ~0.5 s CPU to import, paid by every command that imports the analysis otherwise

    d = np.concatenate([r[rows] - savgol_filter(r[rows], NOISE_WINDOW, 2, mode="interp") for rows in usable])
    sigma = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / NOISE_SMOOTH_FACTOR
    return NoiseEstimate(sigma, "residual about a local quadratic smooth of itself", count)
