"""Integrating a quantity along time (for effects with a memory; they restart at every segment)."""

from __future__ import annotations

import numpy as np

#: Largest decay (in e-folds) handled in one vectorised block; keeps exp() far from overflow.
_BLOCK_EFOLDS = 300.0


def first_order_lag(time_s: np.ndarray, u: np.ndarray, tau_s: float) -> np.ndarray:
    """Response y of dy/dt = (u - y)/tau to u linear between samples, starting in equilibrium.

    Exact for piecewise-linear input: y1 = a y0 + b with a = exp(-dt/tau) and
    b = u1 - s tau - a (u0 - s tau), s = du/dt.
    """
    u = np.asarray(u, float)
    if len(u) == 0:
        return np.empty_like(u)
    dt = np.maximum(np.diff(time_s), 0.0)
    efolds = dt / tau_s
    a = np.exp(-efolds)
    slope_tau = np.divide(np.diff(u), dt, out=np.zeros_like(dt), where=dt > 0) * tau_s
    b = u[1:] - slope_tau - a * (u[:-1] - slope_tau)
    return linear_recurrence(efolds, b, float(u[0]))


def relaxation(time_s: np.ndarray, rate_per_s: np.ndarray, target: np.ndarray, start: float) -> np.ndarray:
    """y of dy/dt = -rate (y - target), from y = ``start`` at the first sample.

    ``rate_per_s`` and ``target`` hold one value per interval (len(time_s) - 1): over an interval
    both are constant, so y1 = target + (y0 - target) exp(-rate dt) exactly.
    """
    dt = np.maximum(np.diff(time_s), 0.0)
    efolds = np.asarray(rate_per_s, float) * dt
    target = np.asarray(target, float)
    return linear_recurrence(efolds, -np.expm1(-efolds) * target, start)


def linear_recurrence(efolds: np.ndarray, b: np.ndarray, start: float) -> np.ndarray:
    """y with y[0] = start and y[i+1] = exp(-efolds[i]) y[i] + b[i] (efolds >= 0), vectorised.

    Solved in closed form, y_i = A_i (y_0 + sum_j b_j / A_(j+1)) with A the running product of
    exp(-efolds), block by block so that no block decays by more than _BLOCK_EFOLDS.
    """
    n = len(efolds) + 1
    y = np.empty(n)
    y[0] = start
    log_a = np.concatenate([[0.0], np.cumsum(-efolds)])
    begin = 0
    while begin < n - 1:
        if efolds[begin] > _BLOCK_EFOLDS:  # a long gap: the past is forgotten in one step
            y[begin + 1] = np.exp(-efolds[begin]) * y[begin] + b[begin]
            begin += 1
            continue
        stop = int(np.searchsorted(-log_a, -log_a[begin] + _BLOCK_EFOLDS, side="right"))
        stop = min(max(stop, begin + 2), n)
        rel = log_a[begin + 1:stop] - log_a[begin]
        y[begin + 1:stop] = np.exp(rel) * (y[begin] + np.cumsum(b[begin:stop - 1] * np.exp(-rel)))
        begin = stop - 1
    return y
