"""How noisy are the data? Estimated from the data themselves, so structure can be told from noise.

One estimator for the whole analysis (fit and diagnosis report the same noise). The noise is not one
number: each reading's is its phase class's reading noise and its share of the slide's positioning
scatter, ``NoiseEstimate.sigma_ppm(data)``.

Reading noise, per phase class (frequency; coil in air or at the target; room temperature, heated and
steady, or a heater ramping: ``phase_classes``), each found

1. from repeats: pairs of successive readings of one state (same recording, frequency, distance and
   direction, close in time and temperature). Their difference holds only the bridge's noise;
2. without enough repeats: the residual minus a flexible smooth of itself (a local quadratic over
   ``NOISE_WINDOW`` successive readings of one run of like readings, ``reading_groups``: a
   Savitzky-Golay filter), scaled robustly (MAD). The smooth follows slopes and bends of the
   residual (structure the model leaves), so structure cannot inflate the estimate the way
   successive differences do, and the MAD keeps single glitches from inflating it either. Each of
   these readings is its own visit of the slide, so its scatter also holds the positioning share:
   that share is taken out (it is counted once, as positioning). Asked to (``beside_sweeps``, as the
   diagnosis judges its final residual), what every sweep over the same positions shares is taken out
   before the smooth (``_off_profile``): a bump in x a few positions wide is no noise of the bridge.

A class with few readings is shrunk toward the pooled figure (``SHRINK_READINGS``), so a class of a
handful of readings cannot claim a noise of its own by chance. Structure a smooth cannot follow still
counts as noise in 2.; the diagnosis therefore judges its final model's residual with such classes'
figures found on that model (``refreshed``).

Every figure carries its effective degrees of freedom (``PhaseNoise.dof``): a variance estimated from m
of them has a relative standard error of sqrt(2/m), a margin every test that judges a residual against
the noise must leave (``NoiseEstimate.variance_shares``, ``analysis.noise_margin``). A MAD has 0.3675 the
efficiency of a standard deviation on Gaussian noise (``MAD_EFFICIENCY``), remainders about a smooth are
correlated with their neighbours (``remainder_dof_per_reading``), and a shrunk figure combines the class's
and the pooled estimate's uncertainties by their weights.

Positioning (``analysis.positioning``): each move lands a little off the commanded distance, and every
reading of that visit follows by sigma_x |d ln L / dx|; sigma_x is estimated from revisits of one distance
in one direction where they exist, with the station's declared repeatability
(``Measurements.slide_repeatability_m``) as a prior, and seen through the fitted model's sensitivity.

``NoiseEstimate.ppm``, the figure thresholds are stated in, is the RMS of the per-reading noise over the
readings it was estimated on: the residual RMS a model that explains everything would leave.
``design_effect`` is Kish's for readings of one visit (``analysis.grouping``).

``smooth_residual`` (a running median) is the reference glitches are judged against
(``analysis.outliers``): a median is not pulled toward a glitch.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np
from scipy.optimize import brentq

from ecds_lab.analysis.grouping import design_effect, ramping, visit_labels
from ecds_lab.analysis.positioning import Positioning, estimate_positioning
from ecds_lab.data.measurements import Measurements

#: ``NoiseEstimate.method`` when repeated readings of one state gave the estimate.
REPEATED = "repeated readings"
SMOOTHED = "residual about a local quadratic smooth of itself"
#: Successive readings of one state: at most this far apart in time, and this close in temperature.
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
#: A phase class gets its own estimate from this many repeat pairs, or else this many smoothed readings.
MIN_CLASS_PAIRS = 8
MIN_CLASS_READINGS = 12
#: Shrinkage of a class's variance toward the pooled one: the pooled figure counts as this many readings.
SHRINK_READINGS = 10.0
#: A reading at least this much (K) above the campaign's room temperature is heated (a heater is on).
HEATED_K = 5.0
#: Phase regimes of ``phase_classes``.
REGIMES = ("room temperature", "heated, steady", "heater ramping")
#: The residual below this multiple of the noise a declared positioning figure implies: that figure is too large.
LOW_RESIDUAL_RATIO = 0.5
_MEDIAN_ABS_NORMAL = 0.6744897501960817
#: Asymptotic efficiency of the MAD against the standard deviation on Gaussian data (var(sigma_MAD) = 1.3605
#: sigma^2 / n against sigma^2 / 2n): a MAD-based variance from n independent values has 0.3675 n degrees of freedom.
MAD_EFFICIENCY = 0.3675


@dataclass(frozen=True)
class PhaseNoise:
    """The reading noise of one phase class: frequency, coil in air or not, regime (``REGIMES``); the figure
    used (ppm, shrunk toward the pooled one), the class's own estimate (NaN: too few readings), from how
    many pairs or readings and how."""

    freq_hz: float
    in_air: bool
    regime: int
    sigma_ppm: float
    own_ppm: float
    count: int
    method: str
    #: effective degrees of freedom of ``sigma_ppm``'s square: its relative standard error is sqrt(2 / dof)
    dof: float = math.inf

    def to_json(self) -> dict[str, Any]:
        return {"freq_hz": self.freq_hz, "in_air": self.in_air, "regime": REGIMES[self.regime],
                "sigma_ppm": round(self.sigma_ppm, 3),
                "own_ppm": round(self.own_ppm, 3) if math.isfinite(self.own_ppm) else None,
                "count": self.count, "method": self.method,
                "dof": round(self.dof, 1) if math.isfinite(self.dof) else None}


@dataclass(frozen=True)
class SensitivityTable:
    """|d ln L / dx| (1/m) of the fitted model over the commanded distances, per frequency: what a position
    error does to a reading anywhere in the campaign's range (interpolated; clamped at its ends)."""

    freq_hz: tuple[float, ...] = ()
    x_m: tuple[tuple[float, ...], ...] = ()
    per_m: tuple[tuple[float, ...], ...] = ()

    @classmethod
    def from_rows(cls, data: Measurements, relative_sensitivity_per_m: np.ndarray) -> SensitivityTable:
        s = np.abs(np.asarray(relative_sensitivity_per_m, float))
        ok = np.isfinite(data.x_m) & np.isfinite(s)
        freqs, xs, values = [], [], []
        for f in np.unique(data.freq_hz[ok]):
            rows = ok & (data.freq_hz == f)
            x, inverse = np.unique(data.x_m[rows], return_inverse=True)
            mean = np.bincount(inverse, weights=s[rows]) / np.bincount(inverse)
            freqs.append(float(f))
            xs.append(tuple(x.tolist()))
            values.append(tuple(mean.tolist()))
        return cls(tuple(freqs), tuple(xs), tuple(values))

    def __call__(self, data: Measurements) -> np.ndarray:
        """|d ln L / dx| (1/m) at every row of ``data`` (0 in air, or with an empty table)."""
        out = np.zeros(len(data))
        if not self.freq_hz:
            return out
        target = np.isfinite(data.x_m)
        table_f = np.asarray(self.freq_hz)
        for f in np.unique(data.freq_hz[target]):
            k = int(np.argmin(np.abs(np.log(table_f) - math.log(f)))) if f > 0 else 0
            rows = target & (data.freq_hz == f)
            out[rows] = np.interp(data.x_m[rows], self.x_m[k], self.per_m[k])
        return out


@dataclass(frozen=True)
class NoiseEstimate:
    """Noise of one reading in ppm of L: the bridge's reading noise (how it was found, from how many
    pairs or readings; RMS over the readings, per phase class in ``classes``) and the positioning
    scatter's share (0 when neither declared nor seen in revisits)."""

    reading_ppm: float
    method: str
    pairs: int
    positioning_ppm: float = 0.0
    #: How many correlated readings count as one independent one (>= 1): readings of one visit share its
    #: position error. Chi-square and BIC gains are divided by it.
    design_effect: float = 1.0
    #: the reading noise per phase class; empty: ``reading_ppm`` for every reading
    classes: tuple[PhaseNoise, ...] = ()
    #: the pooled reading noise (all classes together), the figure a reading of an unseen class gets
    pooled_ppm: float = math.nan
    #: effective degrees of freedom of ``pooled_ppm``'s square
    pooled_dof: float = math.inf
    #: room temperature of the campaign the classes were found on (C): readings this much above it are heated
    room_c: float = math.nan
    positioning: Positioning = field(default_factory=Positioning)
    #: not compared: it only matters through the positioning figures, which are
    sensitivity: SensitivityTable = field(default_factory=SensitivityTable, compare=False)
    #: things the user must know about the noise (e.g. a declared figure far larger than the data show)
    warnings: tuple[str, ...] = ()

    def sigma_ppm(self, data: Measurements) -> np.ndarray:
        """The noise of each reading of ``data`` (ppm of L), in its order, from its attributes only (frequency,
        phase, distance): its class's reading noise and its positioning share in quadrature. Residuals times
        ``ppm / sigma_ppm(data)`` weigh every reading by its own noise."""
        return np.hypot(self.reading_sigma_ppm(data), self.positioning_sigma_ppm(data))

    def reading_sigma_ppm(self, data: Measurements) -> np.ndarray:
        """The bridge's reading noise of each reading of ``data`` (ppm): its phase class's figure."""
        return self._class_figures()[self._class_index(data)]

    def _class_index(self, data: Measurements) -> np.ndarray:
        """Each reading's index into ``classes``; -1 (the pooled figure) for a class not among them."""
        if not self.classes:
            return np.full(len(data), -1)
        return _class_index(self.classes, phase_classes(data, self.room_c))

    def _class_figures(self) -> np.ndarray:
        """The classes' reading noise (ppm), then the figure a reading of no class gets (index -1)."""
        fallback = self.pooled_ppm if math.isfinite(self.pooled_ppm) else self.reading_ppm
        return np.array([*(c.sigma_ppm for c in self.classes), fallback])

    def variance_shares(self, data: Measurements) -> tuple[np.ndarray, np.ndarray]:
        """How each reading's noise variance splits over the estimates it comes from, and how well each is known:
        a (readings x estimates) array of shares (each row sums to 1; the estimates are the phase classes, the
        pooled figure, the positioning) and the effective degrees of freedom of each estimate (inf: known, as a
        declared positioning figure taken as stated)."""
        index = self._class_index(data)
        reading = self._class_figures()[index] ** 2
        position = self.positioning_sigma_ppm(data) ** 2
        total = reading + position
        reading_share = np.divide(reading, total, out=np.ones(len(data)), where=total > 0)
        shares = np.zeros((len(data), len(self.classes) + 2))
        # a reading of no class (index -1) takes its noise from the pooled figure, the column before the last
        shares[np.arange(len(data)), np.where(index >= 0, index, len(self.classes))] = reading_share
        shares[:, -1] = 1.0 - reading_share
        dof = np.array([*(c.dof for c in self.classes), self.pooled_dof, self.positioning.variance_dof])
        return shares, dof

    def positioning_sigma_ppm(self, data: Measurements) -> np.ndarray:
        """The positioning scatter's share of each reading (ppm): sigma_x |d ln L / dx|, 0 in air."""
        sigma = self.positioning.sigma_m
        if not sigma > 0:
            return np.zeros(len(data))
        return sigma * self.sensitivity(data) * 1e6

    @property
    def ppm(self) -> float:
        """The noise models are judged against: reading and positioning parts (RMS each) in quadrature."""
        return math.hypot(self.reading_ppm, self.positioning_ppm)

    @property
    def source(self) -> str:
        """Where the noise comes from, in words: the reading part's method, and the positioning part's."""
        return noise_parts_text(self.to_json()) or self.method

    def to_json(self) -> dict[str, float | str]:
        return {"reading_ppm": round(self.reading_ppm, 3), "positioning_ppm": round(self.positioning_ppm, 3),
                "method": self.method}

    def details_json(self) -> dict[str, Any]:
        """Everything behind the figures: phase classes, positioning (declared, from revisits, used), the
        design effect and the warnings."""
        p = self.positioning
        return {"classes": [c.to_json() for c in self.classes],
                "positioning": {"declared_um": round(p.declared_m * 1e6, 4),
                                "from_revisits_um": round(p.from_data_m * 1e6, 4) if math.isfinite(p.from_data_m)
                                else None,
                                "revisit_dof": round(p.dof, 1), "used_um": round(p.sigma_m * 1e6, 4),
                                "source": p.source},
                "design_effect": round(self.design_effect, 3), "warnings": list(self.warnings)}


def noise_parts_text(parts: Mapping[str, Any]) -> str:
    """The noise's two parts in words, from ``NoiseEstimate.to_json()`` (as the JSON reports carry it);
    empty when there is no positioning part (the noise is then the reading noise alone)."""
    if not parts.get("positioning_ppm"):
        return ""
    return (f"reading {parts['reading_ppm']:.1f} ppm from {parts['method']}, slide positioning "
            f"{parts['positioning_ppm']:.1f} ppm from the declared repeatability or revisits of the same distances")


def phase_classes(data: Measurements, room_c: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The phase class of every row: frequency, coil in air, regime (index into ``REGIMES``: 0 room
    temperature, 1 heated and steady, 2 a heater ramping; heated = ``HEATED_K`` above ``room_c``)."""
    hot = np.maximum(data.t_coil_c, data.t_target_c) - room_c > HEATED_K if math.isfinite(room_c) else \
        np.zeros(len(data), bool)
    regime = np.where(ramping(data), 2, np.where(hot, 1, 0))
    return data.freq_hz, data.in_air, regime


def _class_index(classes: tuple[PhaseNoise, ...], keys: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Each row's index into ``classes`` (-1 for a class not among them)."""
    freq, air, regime = keys
    index = np.full(len(freq), -1)
    for k, c in enumerate(classes):
        index[(freq == c.freq_hz) & (air == c.in_air) & (regime == c.regime)] = k
    return index


def room_temperature_c(data: Measurements) -> float:
    """The campaign's room temperature (C): the 5th percentile of the cooler of the coil and target readings."""
    return float(np.percentile(np.minimum(data.t_coil_c, data.t_target_c), 5)) if len(data) else math.nan


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


def running_median(values: np.ndarray, size: int) -> np.ndarray:
    """The median of each reading's window of ``size`` (odd) readings centred on it, the ends repeated beyond the
    first and last (``scipy.ndimage.median_filter(values, size, mode="nearest")``, the same numbers: a median of an
    odd count is one of the values). Not through scipy.ndimage: importing it costs every command 0.24 s."""
    if size < 1 or size % 2 == 0:
        raise ValueError(f"a running median's window must be a positive odd number of readings, not {size}")
    values = np.asarray(values, float)
    if len(values) == 0:
        return values.copy()
    padded = np.pad(values, size // 2, mode="edge")
    return np.median(np.lib.stride_tricks.sliding_window_view(padded, size), axis=1)


def smooth_residual(data: Measurements, residuals_ppm: np.ndarray, window: int = SMOOTH_WINDOW,
                    groups: list[np.ndarray] | None = None) -> np.ndarray:
    """Running median of the residual along each series of like readings (``reading_groups``, or ``groups``
    when the caller has them already)."""
    r = np.asarray(residuals_ppm, float)
    out = r.copy()
    for rows in groups if groups is not None else reading_groups(data):
        if len(rows) >= 3:
            out[rows] = running_median(r[rows], min(window, len(rows) - (1 - len(rows) % 2)))
    return out


def _repeat_pairs(data: Measurements, residuals_ppm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Differences of successive residuals of one state (see the module docstring), and the two rows of each
    (earlier, later; one pair per row of the array)."""
    order = np.lexsort((data.time_s, data.direction, data.x_commanded_m, data.freq_hz, data.segment))
    r = residuals_ppm[order]
    if len(r) < 2:
        return np.zeros(0), np.zeros((0, 2), int)
    same = np.ones(len(r) - 1, bool)
    for key in (data.segment, data.freq_hz, data.x_commanded_m, data.direction):
        k = key[order]
        same &= (k[1:] == k[:-1]) | (np.isinf(k[1:]) & np.isinf(k[:-1])) if k.dtype.kind == "f" else k[1:] == k[:-1]
    t, tc, tt = (a[order] for a in (data.time_s, data.t_coil_c, data.t_target_c))
    same &= np.abs(np.diff(t)) <= MAX_GAP_S
    same &= (np.abs(np.diff(tc)) <= MAX_TEMPERATURE_STEP_K) & (np.abs(np.diff(tt)) <= MAX_TEMPERATURE_STEP_K)
    return np.diff(r)[same], np.column_stack([order[:-1][same], order[1:][same]])


def local_quadratic(values: np.ndarray, window: int) -> np.ndarray:
    """Savitzky-Golay smooth of order 2 over an odd ``window`` (at most ``len(values)``), exactly as
    ``scipy.signal.savgol_filter(values, window, 2, mode="interp")`` but without its per-call edge fits,
    which made it the cost of the noise estimate (hundreds of short runs per campaign)."""
    v = np.asarray(values, float)
    coefficients, first, last = _operators(window)
    half = window // 2
    out = np.convolve(v, coefficients, mode="same")
    out[:half] = first @ v[:window]
    out[-half:] = last @ v[-window:]
    return out


@cache
def _operators(window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The smooth's coefficients inside, and the rows of its operator for the first and last ``window // 2``
    points: all rows of the projection onto quadratics over ``window`` points (a least-squares quadratic
    through them, read at each point), the Savitzky-Golay filter of order 2 that scipy.signal builds, made
    here with numpy since importing scipy.signal (and scipy.stats with it) costs every command ~0.4 s CPU."""
    t = np.arange(window) - window // 2
    basis = np.vander(t, 3, increasing=True).astype(float)
    projection = basis @ np.linalg.pinv(basis)
    return projection[window // 2][::-1].copy(), projection[: window // 2], projection[window - window // 2:]


def _smooth_remainders(data: Measurements, r: np.ndarray, beside_sweeps: bool = False
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The residual about a local quadratic smooth of itself along each run of like readings long enough
    for one (``NOISE_WINDOW``), the rows they belong to, and each remainder's degrees of freedom (as a share of
    a whole reading's); with ``beside_sweeps``, what the sweeps over the same positions share is taken out first
    (``_off_profile``)."""
    usable = [rows for rows in reading_groups(data) if len(rows) >= NOISE_WINDOW]
    centred, weight = r, np.ones(len(r))
    if beside_sweeps:
        usable, centred, weight = _off_profile(data, r, usable)
    if not usable:
        return np.zeros(0), np.zeros(0, int), np.zeros(0)
    u = np.concatenate([centred[rows] - local_quadratic(centred[rows], NOISE_WINDOW) for rows in usable])
    rows = np.concatenate(usable)
    return u, rows, weight[rows]


def _off_profile(data: Measurements, r: np.ndarray, runs: list[np.ndarray]
                 ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The runs and the residual less what the sweeps over the same positions share. Among runs facing the target
    at one frequency in one direction, a commanded distance read in k >= 2 of them (m readings) loses their mean,
    scaled by sqrt(m / (m - 1)) so pure noise keeps its size, and each of those readings counts as (m - 1) / m of
    one; a run keeps only such readings, if NOISE_WINDOW of them and most of it remain (else it is left whole).
    Structure that lives in x alone (a bump where the coil passes a bracket, a lead screw's period) is the same in
    every sweep and is no noise of the bridge; a smooth cannot follow a bump a few positions wide, so without this
    it counted as noise and hid itself. What differs between the sweeps (the temperatures' effects) is slow along x
    and left to the smooth."""
    centred, weight = r.copy(), np.ones(len(r))
    sweeps: dict[tuple[float, float], list[int]] = {}
    for number, rows in enumerate(runs):
        if not data.in_air[rows].any() and np.isfinite(data.x_commanded_m[rows]).all():
            sweeps.setdefault((float(data.freq_hz[rows[0]]), float(data.direction[rows[0]])), []).append(number)
    out = list(runs)
    for members in sweeps.values():
        if len(members) < 2:
            continue
        lengths = [len(runs[n]) for n in members]
        rows = np.concatenate([runs[n] for n in members])
        run = np.repeat(np.arange(len(members)), lengths)
        _, at = np.unique(np.round(data.x_commanded_m[rows], 7), return_inverse=True)
        readings = np.bincount(at).astype(float)
        distinct = np.unique(at * len(members) + run) // len(members)  # one entry per (position, run)
        shared = np.bincount(distinct, minlength=len(readings)) >= 2
        mean = np.bincount(at, weights=r[rows]) / readings
        m = readings[at]
        keep = shared[at]
        centred[rows[keep]] = (r[rows] - mean[at])[keep] * np.sqrt(m[keep] / (m[keep] - 1.0))
        weight[rows[keep]] = (m[keep] - 1.0) / m[keep]
        for n, kept_here in zip(members, np.split(keep, np.cumsum(lengths)[:-1]), strict=True):
            if len(runs[n]) > kept_here.sum() >= max(NOISE_WINDOW, len(runs[n]) / 2):
                out[n] = runs[n][kept_here]
            elif not kept_here.all():  # too little of it is shared: left whole, as it was
                centred[runs[n]], weight[runs[n]] = r[runs[n]], 1.0
    return out, centred, weight


def _smoothed_sigma(u: np.ndarray, shared_ppm: np.ndarray) -> float:
    """Reading noise from remainders about a smooth: the sigma whose sum in quadrature with each reading's
    positioning share ``shared_ppm`` makes the remainders' median absolute deviation what Gaussian noise
    gives (without a share: 1.4826 MAD / ``NOISE_SMOOTH_FACTOR``, as before)."""
    centred = np.abs(u - np.median(u)) / NOISE_SMOOTH_FACTOR
    alone = float(np.median(centred)) / _MEDIAN_ABS_NORMAL
    if not (shared_ppm > 0).any() or not alone > 0:
        return alone

    def excess(sigma: float) -> float:
        return float(np.median(centred / np.sqrt(sigma**2 + shared_ppm**2))) - _MEDIAN_ABS_NORMAL

    floor = 0.1 * alone  # positioning cannot explain all of the scatter: the bridge is never noiseless
    if excess(floor) <= 0:
        return floor
    # where the median remainder has no positioning share, the root is ``alone`` itself, and rounding can leave the
    # excess there a hair above zero (brentq then refuses the bracket: a study campaign's diagnosis failed so)
    return alone if excess(alone) >= 0 else float(brentq(excess, floor, alone, xtol=1e-6 * alone))


@dataclass(frozen=True)
class _Samples:
    """What the readings say about their noise: repeat differences (with their two rows) and remainders about
    a smooth (with their rows)."""

    pairs: np.ndarray
    pair_rows: np.ndarray
    remainders: np.ndarray
    remainder_rows: np.ndarray
    remainder_weights: np.ndarray

    def sigma(self, rows: np.ndarray, shared_ppm: np.ndarray, min_pairs: int, min_readings: int
              ) -> tuple[float, int, str, float]:
        """The pooled reading noise of the readings ``rows`` (boolean mask) selects: from repeats where there
        are ``min_pairs``, else from remainders where there are ``min_readings``; NaN when neither. With the
        count, the method and the effective degrees of freedom of the variance."""
        in_pairs = rows[self.pair_rows].all(axis=1)
        if in_pairs.sum() >= min_pairs:
            n = int(in_pairs.sum())
            return _robust_sigma(self.pairs[in_pairs]), n, REPEATED, MAD_EFFICIENCY * n
        return self._smoothed(rows, shared_ppm, min_readings)

    def class_sigma(self, rows: np.ndarray, shared_ppm: np.ndarray) -> tuple[float, int, str, float]:
        """The reading noise of one phase class: repeats speak for the readings that have a repeat partner,
        remainders about a smooth for the others (a ramp's readings rarely repeat a state, while its last,
        settled readings may), the two variances weighted by the readings behind each; NaN with too few.
        The degrees of freedom combine the parts' by their weights in the variance (``combined_dof``)."""
        in_pairs = rows[self.pair_rows].all(axis=1)
        parts = []
        if in_pairs.sum() >= MIN_CLASS_PAIRS:
            paired = np.zeros(len(rows), bool)
            paired[self.pair_rows[in_pairs].ravel()] = True
            parts.append((_robust_sigma(self.pairs[in_pairs]), int(paired.sum()), REPEATED,
                          MAD_EFFICIENCY * float(in_pairs.sum())))
            rows = rows & ~paired
        smoothed = self._smoothed(rows, shared_ppm, MIN_CLASS_READINGS)
        if math.isfinite(smoothed[0]):
            parts.append(smoothed)
        if not parts:
            return math.nan, int(rows.sum()), "", 0.0
        count = sum(n for _, n, _, _ in parts)
        sigma = math.sqrt(sum(n * v**2 for v, n, _, _ in parts) / count)
        dof = combined_dof([n * v**2 for v, n, _, _ in parts], [m for _, _, _, m in parts])
        return sigma, count, " and ".join(how for _, _, how, _ in parts), dof

    def _smoothed(self, rows: np.ndarray, shared_ppm: np.ndarray, min_readings: int
                  ) -> tuple[float, int, str, float]:
        selected = rows[self.remainder_rows]
        chosen = self.remainder_rows[selected]
        if len(chosen) >= min_readings:
            u = self.remainders[selected]
            return (_smoothed_sigma(u, shared_ppm[chosen]), len(chosen), SMOOTHED,
                    remainder_dof_per_reading() * float(self.remainder_weights[selected].sum()))
        return math.nan, int(rows.sum()), "", 0.0


def combined_dof(parts: list[float], dofs: list[float]) -> float:
    """Effective degrees of freedom of a sum of independent variance estimates (``parts``, each with its ``dofs``):
    the Welch-Satterthwaite formula, (sum v)^2 / sum (v^2 / m)."""
    total = sum(parts)
    spread = sum(v * v / m for v, m in zip(parts, dofs, strict=True) if v > 0)
    return total * total / spread if spread > 0 else math.inf


@cache
def remainder_dof_per_reading(window: int = NOISE_WINDOW) -> float:
    """Degrees of freedom per reading of a MAD-based variance from remainders about a local quadratic over
    ``window`` readings of white Gaussian noise: neighbouring remainders share their smooth and are correlated
    (rho_k of the filter 1 - h), so the MAD's indicators 1{|u| < median} are too; their covariance follows from the
    Hermite expansion of the indicator, cov_k = sum over even j of a_j^2 rho_k^j / j!, a_j = -2 He_{j-1}(q) phi(q)
    at the median q of |u|. For 7 readings: 0.277 (a Monte Carlo of 4,000 runs of 200: 0.29)."""
    filter_ = -_operators(window)[0]
    filter_[window // 2] += 1.0
    autocovariance = np.correlate(filter_, filter_, "full")
    rho = autocovariance[window:] / autocovariance[window - 1]
    q = _MEDIAN_ABS_NORMAL
    density = math.exp(-q * q / 2) / math.sqrt(2 * math.pi)
    shared = 0.0
    for j in range(2, 30, 2):
        a_j = -2.0 * float(np.polynomial.hermite_e.hermeval(q, np.eye(j)[j - 1])) * density
        shared += a_j * a_j * float(np.sum(rho**j)) / math.factorial(j)
    return MAD_EFFICIENCY / (1.0 + 2.0 * shared / 0.25)


def estimate_noise(data: Measurements, residuals_ppm: np.ndarray,
                   relative_sensitivity_per_m: np.ndarray | None = None, *, beside_sweeps: bool = False
                   ) -> NoiseEstimate:
    """Noise of each reading (ppm of L) from model residuals (see the module docstring): the reading noise
    per phase class, the positioning scatter (with the model's d ln L / dx per reading,
    ``relative_sensitivity_per_m``, from revisits and the declared figure), the design effect of visits,
    and warnings. ``residuals_ppm`` are model residuals, so slow changes the model already explains do not
    count as noise either way. ``beside_sweeps``: the figures found about a smooth leave out what every sweep over
    the same positions shares (``_off_profile``), as a final model's residual is judged."""
    r = np.asarray(residuals_ppm, float)
    samples = _Samples(*_repeat_pairs(data, r), *_smooth_remainders(data, r, beside_sweeps))
    room = room_temperature_c(data)
    keys = phase_classes(data, room)
    table = SensitivityTable() if relative_sensitivity_per_m is None else \
        SensitivityTable.from_rows(data, relative_sensitivity_per_m)
    s_ppm = None if relative_sensitivity_per_m is None else \
        np.nan_to_num(np.abs(np.asarray(relative_sensitivity_per_m, float)) * 1e6, nan=0.0, posinf=0.0)
    shared = np.zeros(len(data))
    visits = visit_labels(data)
    estimate, reading = _with_classes(r, samples, keys, room, shared)
    positioning = estimate_positioning(data, r, reading, s_ppm, visits)
    for again in (True, False):  # the reading noise and the positioning each need the other: two rounds
        if s_ppm is None or not positioning.sigma_m > 0:
            break
        shared = positioning.sigma_m * s_ppm
        estimate, reading = _with_classes(r, samples, keys, room, shared)
        if not again or not positioning.dof > 0:
            break
        positioning = estimate_positioning(data, r, reading, s_ppm, visits)
    positioning_ppm = float(np.sqrt(np.mean(shared**2))) if len(shared) else 0.0
    deff = visit_design_effect(data, r, np.hypot(reading, shared), visits)
    return NoiseEstimate(estimate.reading_ppm, estimate.method, estimate.pairs, positioning_ppm, deff,
                         estimate.classes, estimate.pooled_ppm, estimate.pooled_dof, room, positioning, table,
                         tuple(_warnings(r, reading, positioning, s_ppm)))


def _with_classes(r: np.ndarray, samples: _Samples, keys: tuple[np.ndarray, np.ndarray, np.ndarray], room: float,
                  shared: np.ndarray) -> tuple[NoiseEstimate, np.ndarray]:
    """The reading noise, pooled and per phase class (``keys``, shrunk toward the pooled), with positioning
    shares ``shared`` (ppm per row) taken out of estimates from remainders; and each row's figure."""
    everything = np.ones(len(r), bool)
    pooled, count, method, pooled_dof = samples.sigma(everything, shared, MIN_PAIRS, MIN_SMOOTH_READINGS)
    if not math.isfinite(pooled):
        pooled = float(1.4826 * np.median(np.abs(r - np.median(r)))) if len(r) else math.nan
        method = "robust spread of the residual (too few readings)"
        pooled_dof = MAD_EFFICIENCY * len(r)
    freq, air, regime = keys
    frequencies, index = np.unique(freq, return_inverse=True)
    code = (index.ravel() * 2 + air) * len(REGIMES) + regime
    classes, reading = [], np.full(len(r), pooled)
    for c in np.unique(code):
        rows = code == c
        f, a, g = frequencies[c // (2 * len(REGIMES))], bool(c // len(REGIMES) % 2), int(c % len(REGIMES))
        own, n, how, own_dof = samples.class_sigma(rows, shared)
        used, dof = (pooled, pooled_dof) if not math.isfinite(own) else _shrunk(own, n, own_dof, pooled, pooled_dof)
        classes.append(PhaseNoise(float(f), bool(a), int(g), used, own, n, how or f"pooled ({method})", dof))
        reading[rows] = used
    rms = float(np.sqrt(np.mean(reading**2))) if len(reading) else pooled
    return NoiseEstimate(rms, method, count, classes=tuple(classes), pooled_ppm=pooled, pooled_dof=pooled_dof,
                         room_c=room), reading


def _shrunk(own: float, n: int, own_dof: float, pooled: float, pooled_dof: float) -> tuple[float, float]:
    """A class's figure shrunk toward the pooled one (the pooled counts as ``SHRINK_READINGS`` readings), and the
    effective degrees of freedom of the shrunk variance (``combined_dof`` of the two weighted parts)."""
    parts = [n * own**2, SHRINK_READINGS * pooled**2]
    return math.sqrt(sum(parts) / (n + SHRINK_READINGS)), combined_dof(parts, [own_dof, pooled_dof])


def refreshed(noise: NoiseEstimate, claimed: NoiseEstimate, data: Measurements) -> NoiseEstimate:
    """``noise`` with the figures of its phase classes not found from repeats alone (and the pooled figure, when it
    is not) taken from ``claimed``, the estimate on the residual of a model that explains more of ``data`` (one the
    diagnosis claimed). About a smooth, structure a model leaves that a local quadratic over ``NOISE_WINDOW``
    readings cannot follow counts as noise (a sweep of nine positions: 2.5-4x the bridge's at the target on the
    baseline's residual); repeat differences do not hold it, so those figures stay. Each figure keeps its degrees
    of freedom, which the tests that judge a residual against it count (``analysis.noise_margin``)."""
    new = {(c.freq_hz, c.in_air, c.regime): c for c in claimed.classes}
    classes = tuple(c if c.method == REPEATED else new.get((c.freq_hz, c.in_air, c.regime), c) for c in noise.classes)
    pooled = (noise.pooled_ppm, noise.pooled_dof) if noise.method == REPEATED else \
        (claimed.pooled_ppm, claimed.pooled_dof)
    if classes == noise.classes and pooled == (noise.pooled_ppm, noise.pooled_dof):
        return noise
    updated = dataclasses.replace(noise, classes=classes, pooled_ppm=pooled[0], pooled_dof=pooled[1])
    reading = updated.reading_sigma_ppm(data)
    return dataclasses.replace(updated, reading_ppm=float(np.sqrt(np.mean(reading**2))) if len(reading) else
                               updated.reading_ppm)


def visit_design_effect(data: Measurements, residuals_ppm: np.ndarray, sigma_ppm: np.ndarray,
                        visits: np.ndarray | None = None) -> float:
    """Kish's design effect of the readings at the target clustered by visit (``grouping``): the intraclass
    correlation of the residuals in noise units, about a smooth of the visit means along each run of like
    readings (so structure the model leaves, smooth over a sweep, is not taken for shared error); 1 without
    visits of more than one reading."""
    target = np.isfinite(data.x_m) & (sigma_ppm > 0) & np.isfinite(residuals_ppm)
    visits = visit_labels(data) if visits is None else visits
    if not target.any() or np.bincount(visits[target]).max(initial=0) < 2:
        return 1.0
    z = np.where(target, residuals_ppm / np.where(sigma_ppm > 0, sigma_ppm, 1.0), 0.0)
    run = np.zeros(len(data), int)
    for k, rows in enumerate(reading_groups(data)):
        run[rows] = k
    rows = np.flatnonzero(target)
    rows = rows[np.lexsort((data.time_s[rows], run[rows]))]
    cell = np.concatenate([[True], (run[rows][1:] != run[rows][:-1]) | (visits[rows][1:] != visits[rows][:-1])])
    key = np.cumsum(cell) - 1  # one number per (run, visit), in time order within each run
    means = np.bincount(key, weights=z[rows]) / np.bincount(key)
    cell_run = run[rows][cell]
    smooth = np.empty(len(means))
    for start, stop in zip(*_runs(cell_run), strict=True):
        part = means[start:stop]
        size = len(part)
        smooth[start:stop] = local_quadratic(part, min(NOISE_WINDOW, size - 1 + size % 2)) if size >= 5 else part.mean()
    about = z[rows] - smooth[key]
    return design_effect(about, visits[rows])


def _runs(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop indices of the runs of equal values in ``labels``."""
    edges = np.flatnonzero(np.diff(labels)) + 1
    return np.r_[0, edges], np.r_[edges, len(labels)]


def _warnings(r: np.ndarray, reading: np.ndarray, p: Positioning, s_ppm: np.ndarray | None) -> list[str]:
    """What the user must know: a declared positioning figure that the residual or the revisits show too large
    (``reading``: each row's reading noise)."""
    out = []
    if p.declared_m > 0 and s_ppm is not None and len(r):
        stated = np.hypot(reading, p.declared_m * s_ppm)
        ratio = float(np.sqrt(np.mean(r**2)) / np.sqrt(np.mean(stated**2)))
        if ratio < LOW_RESIDUAL_RATIO:
            out.append(f"the residual ({np.sqrt(np.mean(r**2)):.1f} ppm) is {ratio:.2f}x the noise the declared "
                       f"slide repeatability of {p.declared_m * 1e6:.3g} um implies: the declared figure is too "
                       "large and would hide real effects")
        if p.dof >= 10 and math.isfinite(p.from_data_m) and p.from_data_m < LOW_RESIDUAL_RATIO * p.declared_m:
            out.append(f"revisits of the same distances show a slide repeatability of {p.from_data_m * 1e6:.3g} um "
                       f"({p.dof:.0f} differences), under half the declared {p.declared_m * 1e6:.3g} um")
    return out
