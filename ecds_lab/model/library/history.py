"""Integrating a quantity along time (for effects with a memory; they restart at every segment)."""

from __future__ import annotations

import numpy as np

#: Largest decay (in e-folds) handled in one vectorised block; keeps exp() far from overflow.
_BLOCK_EFOLDS = 300.0


def first_order_lag(time_s: np.ndarray, u: np.ndarray, tau_s: float) -> np.ndarray:
    """Response y of dy/dt = (u - y)/tau to u linear between samples, starting in equilibrium.

    Exact for piecewise-linear input: y1 = a y0 + b with a = exp(-dt/tau) and
    b = u1 - s tau - a (u0 - s tau), s = du/dt. The linear recurrence is solved in closed form,
    y_i = A_i (y_0 + sum_j b_j / A_j) with A the running product of a, block by block.
    """
    u = np.asarray(u, float)
    y = np.empty_like(u)
    if len(u) == 0:
        return y
    dt = np.maximum(np.diff(time_s), 0.0)
    efolds = dt / tau_s
    a = np.exp(-efolds)
    slope_tau = np.divide(np.diff(u), dt, out=np.zeros_like(dt), where=dt > 0) * tau_s
    b = u[1:] - slope_tau - a * (u[:-1] - slope_tau)
    log_a = np.concatenate([[0.0], np.cumsum(-efolds)])
    y[0] = u[0]
    start = 0
    while start < len(u) - 1:
        if efolds[start] > _BLOCK_EFOLDS:  # a long gap: the past is forgotten in one step
            y[start + 1] = a[start] * y[start] + b[start]
            start += 1
            continue
        stop = int(np.searchsorted(-log_a, -log_a[start] + _BLOCK_EFOLDS, side="right"))
        stop = min(max(stop, start + 2), len(u))
        rel = log_a[start + 1:stop] - log_a[start]
        y[start + 1:stop] = np.exp(rel) * (y[start] + np.cumsum(b[start:stop - 1] * np.exp(-rel)))
        start = stop - 1
    return y
