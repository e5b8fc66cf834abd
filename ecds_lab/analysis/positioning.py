"""The slide's positioning scatter: estimated from revisits, with the station's declared figure as a prior.

Each move of the slide lands a little off the commanded distance at random (sigma_x, 1 sigma), and every
reading of that visit (``grouping.visit_labels``) follows by sigma_x |d ln L / dx|. A fixed error of the
slide at a given distance (lead screw, backlash) is the same on every visit from the same direction, so
the difference between two visits of one commanded distance, approached from the same direction in the
same thermal state, holds only the random part and the readings' own noise:

    var(mean_2 - mean_1) = 2 sigma_x^2 s^2 + sigma_r1^2 / m1 + sigma_r2^2 / m2     (s = |d ln L / dx| in ppm/m)

Slow changes between the two passes (a drift, a state not quite equal) are smooth in x, so each pass's
differences are taken about a local quadratic of themselves along x (``SMOOTH_WINDOW``), and sigma_x is
the value that makes the differences' median absolute size what that variance predicts (robust to a
glitch or two). The declared figure (``Measurements.slide_repeatability_m``, a datasheet's) is a prior
worth ``DECLARED_DOF`` such differences: the two are pooled as variances weighted by their degrees of
freedom (the posterior mean of a conjugate inverse-gamma update).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
from scipy.optimize import brentq, minimize

from ecds_lab.analysis.grouping import visit_labels
from ecds_lab.analysis.phases import phase_labels
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.row_labels import row_labels

#: How many revisit differences the declared figure is worth (a datasheet's 1 sigma, no better).
DECLARED_DOF = 10.0
#: Without a declared figure, the data alone give the positioning once this many revisit pairs exist.
MIN_REVISIT_DOF = 10.0
#: Two visits of one distance count as a revisit when their coil and target temperatures differ by at most
#: this (K): across thermal states, an effect the model lacks would pass for scatter.
REVISIT_TOLERANCE_K = 2.0
#: Passes of at least this many distances are smoothed along x (odd window up to ``SMOOTH_WINDOW``).
MIN_PASS_POINTS = 5
SMOOTH_WINDOW = 7
#: Revisit differences beyond this many of their own sigmas are clipped (a glitch must not look like scatter).
CLIP_SIGMAS = 4.0
#: Median of |z| for a standard normal z.
_MEDIAN_ABS_NORMAL = 0.6744897501960817


@dataclass(frozen=True)
class Positioning:
    """The slide's positioning scatter (1 sigma, m): the declared figure, the revisits' own (with its degrees
    of freedom) and the figure used, which pools the two."""

    declared_m: float = 0.0
    from_data_m: float = math.nan
    dof: float = 0.0

    @property
    def sigma_m(self) -> float:
        """Declared and data figures pooled as variances by degrees of freedom; 0 when neither exists."""
        has_data = self.dof > 0 and math.isfinite(self.from_data_m)
        if self.declared_m > 0:
            if not has_data:
                return self.declared_m
            return math.sqrt((DECLARED_DOF * self.declared_m**2 + self.dof * self.from_data_m**2)
                             / (DECLARED_DOF + self.dof))
        return self.from_data_m if has_data and self.dof >= MIN_REVISIT_DOF else 0.0

    @property
    def variance_dof(self) -> float:
        """Effective degrees of freedom of ``sigma_m``'s square: the revisits' plus the prior's where both are
        pooled, the revisits' alone, or infinite for a declared figure taken as stated (a GUM type-B component)."""
        has_data = self.dof > 0 and math.isfinite(self.from_data_m)
        if self.declared_m > 0:
            return DECLARED_DOF + self.dof if has_data else math.inf
        return self.dof if self.sigma_m > 0 else math.inf

    @property
    def source(self) -> str:
        """Where the figure used comes from, in words."""
        has_data = self.dof > 0 and math.isfinite(self.from_data_m)
        if self.declared_m > 0 and has_data:
            return (f"the declared repeatability ({self.declared_m * 1e6:.2g} um) pooled with revisits "
                    f"({self.from_data_m * 1e6:.2g} um from {self.dof:.0f} revisit differences)")
        if self.declared_m > 0:
            return "the declared repeatability"
        if has_data and self.dof >= MIN_REVISIT_DOF:
            return f"revisits of the same distances ({self.dof:.0f} revisit differences)"
        return "none"


def declared_repeatability_m(data: Measurements) -> float:
    """The station's declared slide repeatability (m): the median of the positive figures at the target."""
    sigma = np.asarray(data.slide_repeatability_m, float)
    sigma = sigma[np.isfinite(data.x_m) & np.isfinite(sigma) & (sigma > 0)]
    return float(np.median(sigma)) if len(sigma) else 0.0


def estimate_positioning(data: Measurements, residuals_ppm: np.ndarray, reading_sigma_ppm: np.ndarray,
                         sensitivity_ppm_per_m: np.ndarray | None, visits: np.ndarray | None = None) -> Positioning:
    """The positioning scatter from revisits (module docstring) with the declared figure as prior;
    ``sensitivity_ppm_per_m`` is |d ln L / dx| * 1e6 per row (None: no model sensitivity, data unused);
    ``visits``: ``grouping.visit_labels(data)`` if already known."""
    declared = declared_repeatability_m(data)
    if sensitivity_ppm_per_m is None:
        return Positioning(declared)
    u, scale, s, pair = _revisit_differences(data, np.asarray(residuals_ppm, float),
                                             np.asarray(reading_sigma_ppm, float),
                                             np.asarray(sensitivity_ppm_per_m, float),
                                             visit_labels(data) if visits is None else visits)
    if not len(u):
        return Positioning(declared)
    across = _across_frequencies(u, scale, s, pair)
    if across is not None:
        return Positioning(declared, *across)
    dof = float(len(u))

    def excess(sigma_x: float) -> float:
        return float(np.median(np.abs(u) / np.sqrt(scale[:, 0] * (2 * sigma_x**2 * s**2) + scale[:, 1])))

    if excess(0.0) <= _MEDIAN_ABS_NORMAL:
        return Positioning(declared, 0.0, dof)
    upper = 1e-6
    while excess(upper) > _MEDIAN_ABS_NORMAL and upper < 1e-2:
        upper *= 4
    if excess(upper) > _MEDIAN_ABS_NORMAL:  # no scatter up to centimetres explains the revisits: not a positioning one
        return Positioning(declared)
    sigma_x = brentq(lambda v: excess(v) - _MEDIAN_ABS_NORMAL, 0.0, upper, xtol=1e-10)
    return Positioning(declared, float(sigma_x), dof)


def _across_frequencies(u: np.ndarray, scale: np.ndarray, s: np.ndarray,
                        pair: np.ndarray) -> tuple[float, float] | None:
    """sigma_x and its degrees of freedom from revisits read at two frequencies: the two frequencies of one
    visit share its position error but not the bridge's noise, so each pair of differences (u_a, u_b) is
    Gaussian with covariance [[c s_a^2 + n_a, c s_a s_b], [c s_a s_b, c s_b^2 + n_b]] (each divided by the
    smooth's reduction first; c = 2 sigma_x^2, n the reading noise's part). c and the two noise variances by maximum
    likelihood, so the reading noise need not be known; each difference clipped at ``CLIP_SIGMAS`` robust
    sigmas first. None with fewer than ``MIN_REVISIT_DOF`` pairs."""
    order = np.lexsort((s, pair))
    twin = pair[order][1:] == pair[order][:-1]
    first, second = order[:-1][twin], order[1:][twin]
    if len(first) < MIN_REVISIT_DOF:
        return None
    a, b = u[first] / np.sqrt(scale[first, 0]), u[second] / np.sqrt(scale[second, 0])
    a, b = (np.clip(v, -CLIP_SIGMAS * _robust_scale(v), CLIP_SIGMAS * _robust_scale(v)) for v in (a, b))
    sa, sb = s[first], s[second]

    def negative_log_likelihood(log_params: np.ndarray) -> float:
        c, na, nb = np.exp(log_params)
        vaa, vbb, vab = c * sa**2 + na, c * sb**2 + nb, c * sa * sb
        det = vaa * vbb - vab**2
        quad = (vbb * a**2 - 2 * vab * a * b + vaa * b**2) / det
        return float(0.5 * np.sum(np.log(det) + quad))

    na0, nb0 = _robust_scale(a) ** 2, _robust_scale(b) ** 2
    c0 = max(float(np.mean(a * b / (sa * sb))), 1e-4 * min(na0 / np.mean(sa**2), nb0 / np.mean(sb**2)))
    start = np.log([c0, na0, nb0])
    best = minimize(negative_log_likelihood, start, method="Nelder-Mead",
                    options={"xatol": 1e-4, "fatol": 1e-6, "maxiter": 2000})
    c = float(np.exp(best.x[0])) if best.success or np.isfinite(best.fun) else math.nan
    return math.sqrt(c / 2), float(len(first))


def _robust_scale(v: np.ndarray) -> float:
    """1.4826 MAD: a standard deviation a glitch does not inflate."""
    return float(1.4826 * np.median(np.abs(v - np.median(v)))) or float(np.std(v)) or 1.0


def _revisit_differences(data: Measurements, r: np.ndarray, reading: np.ndarray, s: np.ndarray,
                         visits: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Differences of successive visits of one distance, direction and frequency in one thermal state, about
    a smooth of themselves along x; with each one's variance factors (of 2 sigma_x^2 s^2 and of the reading
    noise, times the smooth's reduction), its sensitivity and the pair of visits it compares (a number)."""
    target = np.isfinite(data.x_m) & np.isfinite(s) & (s > 0) & np.isfinite(r)
    nothing = np.zeros(0), np.zeros((0, 2)), np.zeros(0), np.zeros(0, int)
    if target.sum() < 2 * MIN_PASS_POINTS:
        return nothing
    rows = np.flatnonzero(target)
    key = row_labels(visits[rows], data.freq_hz[rows])
    count = np.bincount(key).astype(float)

    def mean(values: np.ndarray) -> np.ndarray:
        return np.bincount(key, weights=values[rows]) / count

    m, var_r, sens = mean(r), mean(reading**2) / count, mean(s)
    tc, tt, t = mean(data.t_coil_c), mean(data.t_target_c), mean(data.time_s)
    first = np.zeros(len(count), int)
    first[key[::-1]] = rows[::-1]
    freq, x, direction, segment, phase = (a[first] for a in (data.freq_hz, data.x_commanded_m, data.direction,
                                                              data.segment, phase_labels(data)))
    order = np.lexsort((t, x, direction, freq, segment))
    same = np.ones(len(order) - 1, bool)
    for a in (segment, freq, direction, x):
        same &= a[order][1:] == a[order][:-1]
    same &= (np.abs(np.diff(tc[order])) <= REVISIT_TOLERANCE_K) & (np.abs(np.diff(tt[order])) <= REVISIT_TOLERANCE_K)
    i, j = order[:-1][same], order[1:][same]
    if not len(i):
        return nothing
    rank = _rank_within(order, same)[same]
    d, v, sp = m[j] - m[i], var_r[i] + var_r[j], 0.5 * (sens[i] + sens[j])
    passes = row_labels(segment[i], freq[i], direction[i], phase[i], phase[j], rank)
    u_all, factor_all, keep = np.zeros(len(d)), np.zeros(len(d)), np.zeros(len(d), bool)
    for p in np.unique(passes):
        members = np.flatnonzero(passes == p)
        if len(members) < MIN_PASS_POINTS:
            continue
        members = members[np.argsort(x[i[members]])]
        residual_operator = np.eye(len(members)) - _smoother(len(members))
        u_all[members] = residual_operator @ d[members]
        factor_all[members] = np.sum(residual_operator**2, axis=1)
        keep[members] = True
    scale = np.column_stack([factor_all, factor_all * v])[keep]
    pair = row_labels(visits[first[i]], visits[first[j]])
    return u_all[keep], scale, sp[keep], pair[keep]


def _rank_within(order: np.ndarray, same: np.ndarray) -> np.ndarray:
    """For each successive pair in ``order``, how many pairs of the same key came before it (0, 1, ...)."""
    rank = np.zeros(len(same), int)
    for k in range(1, len(same)):
        rank[k] = rank[k - 1] + 1 if same[k - 1] and same[k] else 0
    return rank


@cache
def _smoother(n: int) -> np.ndarray:
    """The n x n operator of a local quadratic smooth (Savitzky-Golay, odd window up to ``SMOOTH_WINDOW``)."""
    from scipy.signal import savgol_filter  # here, not at the top: scipy.signal (and scipy.stats with it) costs
    # ~0.4 s CPU to import, paid otherwise by every command that imports the analysis (``ecds-lab fit`` too)

    window = min(SMOOTH_WINDOW, n if n % 2 else n - 1)
    return savgol_filter(np.eye(n), window, 2, axis=0, mode="interp")
