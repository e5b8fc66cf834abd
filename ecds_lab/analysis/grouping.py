"""Readings that share an error: visits of the slide and thermal states, and what sharing costs.

A *visit* is one move of the slide: the readings taken after it, in time order, at the same commanded
distance and direction, before the slide moves again (all frequencies and repeats of that stop). Its
readings share the carriage's position error. A *thermal state* is a stretch of one phase whose
temperatures stay within ``STATE_TOLERANCE_K`` of its first reading and are not ramping; its readings
share whatever error that state carries (a thermocouple's offset, a gradient the model does not know).

Correlated readings carry less evidence than their count says. With an intraclass correlation rho
within clusters of mean size m (size-weighted, Kish 1965, "Survey Sampling", sect. 5.4), a chi-square
or a variance of a mean is inflated by the design effect 1 + (m - 1) rho; ``design_effect`` computes it.
"""

from __future__ import annotations

import math

import numpy as np

from ecds_lab.analysis.per_readings import per_readings
from ecds_lab.analysis.phases import phase_labels
from ecds_lab.data.measurements import Measurements

#: A reading whose coil or target temperature changes faster than this (K/s, 3.6 K per hour) is ramping.
RAMP_K_PER_S = 1e-3
#: Half-width (s) of the window over which a temperature's rate is fitted (thermocouple noise of ~0.02 K
#: gives ~5e-5 K/s of noise on a slope over +-300 s, well under ``RAMP_K_PER_S``).
RATE_WINDOW_S = 300.0
#: Readings of one thermal state stay within this of its first reading (K), coil and target alike.
STATE_TOLERANCE_K = 1.0


def visit_labels(data: Measurements) -> np.ndarray:
    """Visit number of every row (0, 1, ...): a new visit when the recording, commanded distance or
    direction changes between successive readings in time; readings in air are each their own visit
    (no position, so nothing positional to share)."""
    labels = np.zeros(len(data), int)
    next_label = 0
    x, direction = data.x_commanded_m, data.direction
    for rows in data.segment_rows:
        if not len(rows):
            continue
        xs, ds = x[rows], direction[rows]
        air = ~np.isfinite(data.x_m[rows])
        same_x = (xs[1:] == xs[:-1]) | (np.isinf(xs[1:]) & np.isinf(xs[:-1]))
        change = np.concatenate([[True], ~same_x | (ds[1:] != ds[:-1]) | air[1:] | air[:-1]])
        labels[rows] = next_label + np.cumsum(change) - 1
        next_label = int(labels[rows].max()) + 1
    return labels


#: The rates found lately, each beside the very columns it was found from (held, so none of them is freed and its
#: id reused while it is here): a diagnosis asks for the rates of the same readings hundreds of times (each
#: reading's noise depends on whether a heater ramps), 2 s of a 10^5-reading report.
_recent_rates: list[tuple[tuple[np.ndarray, ...], np.ndarray]] = []
_RECENT_RATES = 4


def temperature_rates_k_per_s(data: Measurements) -> np.ndarray:
    """The larger of |dT/dt| of the coil and of the target at every row (K/s): the slope of a straight line
    through the readings of the same phase within ``RATE_WINDOW_S``, or its neighbours in time where the
    readings are sparser (never across a pause between phases). Read-only: it may be shared."""
    columns = (data.time_s, data.segment, data.x_m, data.t_coil_c, data.t_target_c)
    for kept, rates in _recent_rates:
        if all(a is b for a, b in zip(kept, columns, strict=True)):
            return rates
    phase = phase_labels(data)
    out = np.zeros(len(data))
    for temperatures in (data.t_coil_c, data.t_target_c):
        out = np.maximum(out, np.abs(_windowed_slope(data.time_s, temperatures, phase, RATE_WINDOW_S)))
    out.setflags(write=False)
    _recent_rates.insert(0, (columns, out))
    del _recent_rates[_RECENT_RATES:]
    return out


def ramping(data: Measurements) -> np.ndarray:
    """Rows taken while a heater ramps (``RAMP_K_PER_S``): the coil or the target still changing."""
    return temperature_rates_k_per_s(data) > RAMP_K_PER_S


def thermal_state_labels(data: Measurements) -> np.ndarray:
    """Thermal state of every row: within one phase, in time order, a new state when the coil or target
    temperature leaves ``STATE_TOLERANCE_K`` of the state's first reading; ramping rows are each their own."""
    labels = np.zeros(len(data), int)
    moving = ramping(data)
    phase = phase_labels(data)
    order = np.lexsort((data.time_s, phase))
    label, reference, last_phase = -1, (math.nan, math.nan), -1
    for i in order:
        here = (data.t_coil_c[i], data.t_target_c[i])
        if (moving[i] or phase[i] != last_phase or not all(abs(a - b) <= STATE_TOLERANCE_K
                                                           for a, b in zip(here, reference, strict=True))):
            label, reference = label + 1, here
        if moving[i]:
            reference = (math.nan, math.nan)
        labels[i], last_phase = label, phase[i]
    return labels


@per_readings
def stretch_labels(data: Measurements) -> np.ndarray:
    """Stretches of readings taken alike, numbered: a thermal state, or the readings of one phase taken while a
    heater ramps one after another (``ramping``). Where an effect's evidence comes from, stretch by stretch
    (``diagnosis.checks.worst_stretch``); worked out once per campaign (``per_readings``), as each candidate beside
    the smooth asks again."""
    states, moving, phase = thermal_state_labels(data), ramping(data), phase_labels(data)
    order = np.lexsort((data.time_s, phase))
    key_state = np.where(moving[order], -1, states[order])
    starts = np.ones(len(order), bool)
    starts[1:] = (phase[order][1:] != phase[order][:-1]) | (key_state[1:] != key_state[:-1])
    labels = np.empty(len(data), int)
    labels[order] = np.cumsum(starts) - 1
    return labels


def intraclass_correlation(values: np.ndarray, labels: np.ndarray) -> float:
    """One-way ANOVA estimate of the intraclass correlation of ``values`` within clusters ``labels``
    (unequal sizes: Searle's n0); 0 when no cluster has two members, clipped to [0, 1]."""
    v = np.asarray(values, float)
    _, key = np.unique(labels, return_inverse=True)
    counts = np.bincount(key)
    groups, n = len(counts), len(v)
    if groups < 2 or n <= groups or counts.max() < 2:
        return 0.0
    means = np.bincount(key, weights=v) / counts
    within = float(np.sum((v - means[key]) ** 2)) / (n - groups)
    between = float(np.sum(counts * (means - v.mean()) ** 2)) / (groups - 1)
    n0 = (n - float(np.sum(counts**2)) / n) / (groups - 1)
    if not within + between > 0:
        return 0.0
    share = (between - within) / n0
    return float(np.clip(share / (share + within), 0.0, 1.0)) if share > 0 else 0.0


def mean_cluster_size(labels: np.ndarray) -> float:
    """Size-weighted mean cluster size sum(m^2) / sum(m): the m of Kish's design effect for unequal clusters."""
    counts = np.unique(labels, return_counts=True)[1].astype(float)
    return float(np.sum(counts**2) / np.sum(counts)) if len(counts) else 1.0


def design_effect(values: np.ndarray, labels: np.ndarray) -> float:
    """Kish's design effect 1 + (m - 1) rho of ``values`` clustered by ``labels`` (>= 1)."""
    return 1.0 + (mean_cluster_size(labels) - 1.0) * intraclass_correlation(values, labels)


def _windowed_slope(t: np.ndarray, v: np.ndarray, group: np.ndarray, half_width_s: float) -> np.ndarray:
    """Least-squares slope dv/dt over the rows of the same ``group`` within +-``half_width_s`` of each row
    (and at least its neighbours in time)."""
    out = np.zeros(len(t))
    for g in np.unique(group):
        rows = np.flatnonzero(group == g)
        rows = rows[np.argsort(t[rows], kind="stable")]
        if len(rows) < 2:
            continue
        tt = t[rows] - t[rows].mean()
        vv = v[rows] - v[rows].mean()
        sums = [np.concatenate([[0.0], np.cumsum(a)]) for a in (np.ones_like(tt), tt, vv, tt * vv, tt * tt)]
        # at least the neighbours either side: a sparse subset of the readings still gets a rate
        index = np.arange(len(tt))
        lo = np.minimum(np.searchsorted(tt, tt - half_width_s, side="left"), np.maximum(index - 1, 0))
        hi = np.maximum(np.searchsorted(tt, tt + half_width_s, side="right"), np.minimum(index + 2, len(tt)))
        n, st, sv, stv, stt = (s[hi] - s[lo] for s in sums)
        denominator = n * stt - st**2
        ok = denominator > 1e-9 * np.maximum(n * stt, 1e-300)
        out[rows[ok]] = (n * stv - st * sv)[ok] / denominator[ok]
    return out
