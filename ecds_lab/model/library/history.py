"""Integrating a quantity along time (for effects with a memory; they restart at every segment)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import lapack

#: Largest decay (in e-folds) handled in one vectorised block; keeps exp() far from overflow.
_BLOCK_EFOLDS = 300.0
#: Longest chunk of rows summed in one row of a 2-D array (their padding stays small).
_CHUNK_ROWS = 64
#: Decay that forgets the past entirely (exp(-_FORGET_EFOLDS) is 0 in double precision).
_FORGET_EFOLDS = 1e4


def _lag_steps(time_s: np.ndarray, u: np.ndarray, tau_s: float) -> tuple[np.ndarray, ...]:
    """Per interval of a first-order lag: its length dt, dt/tau, the decay a = exp(-dt/tau) and the input's slope."""
    dt = np.maximum(np.diff(time_s), 0.0)
    efolds = dt / tau_s
    slope = np.divide(np.diff(u), dt, out=np.zeros_like(dt), where=dt > 0)
    return dt, efolds, np.exp(-efolds), slope


def first_order_lag(time_s: np.ndarray, u: np.ndarray, tau_s: float) -> np.ndarray:
    """Response y of dy/dt = (u - y)/tau to u linear between samples, starting in equilibrium.

    Exact for piecewise-linear input: y1 = a y0 + b with a = exp(-dt/tau) and
    b = u1 - s tau - a (u0 - s tau), s = du/dt.
    """
    u = np.asarray(u, float)
    if len(u) == 0:
        return np.empty_like(u)
    _, efolds, a, slope = _lag_steps(time_s, u, tau_s)
    slope_tau = slope * tau_s
    b = u[1:] - slope_tau - a * (u[:-1] - slope_tau)
    return linear_recurrence(efolds, b, float(u[0]))


def first_order_lag_tau_derivative(time_s: np.ndarray, u: np.ndarray, y: np.ndarray, tau_s: float) -> np.ndarray:
    """dy/dtau of ``first_order_lag`` (y its result): the recurrence differentiated,
    dy1 = a dy0 + (da y0 + db), da = a dt/tau^2, db = -s - da (u0 - s tau) + a s, from dy = 0."""
    u = np.asarray(u, float)
    if len(u) == 0:
        return np.empty_like(u)
    dt, efolds, a, slope = _lag_steps(time_s, u, tau_s)
    da = a * dt / tau_s**2
    db = -slope - da * (u[:-1] - slope * tau_s) + a * slope
    return linear_recurrence(efolds, da * y[:-1] + db, 0.0)


def relaxation(time_s: np.ndarray, rate_per_s: np.ndarray, target: np.ndarray, start: float,
               restart: np.ndarray | None = None) -> np.ndarray:
    """y of dy/dt = -rate (y - target), from y = ``start`` at the first sample.

    ``rate_per_s`` and ``target`` hold one value per interval (len(time_s) - 1): over an interval
    both are constant, so y1 = target + (y0 - target) exp(-rate dt) exactly. ``restart`` (one flag
    per interval) starts y afresh at ``start`` at the end of the flagged intervals (a new recording).
    """
    dt = np.maximum(np.diff(time_s), 0.0)
    efolds = np.asarray(rate_per_s, float) * dt
    b = -np.expm1(-efolds) * np.asarray(target, float)
    if restart is not None and restart.any():
        efolds[restart], b[restart] = _FORGET_EFOLDS, start
    return linear_recurrence(efolds, b, start)


def relaxation_derivatives(time_s: np.ndarray, rate_per_s: np.ndarray, target: np.ndarray, y: np.ndarray,
                           d_rate: np.ndarray, d_target: np.ndarray, restart: np.ndarray | None = None) -> np.ndarray:
    """The derivatives of ``relaxation``'s y (given) along parameters that change the rate by ``d_rate`` and the
    target by ``d_target`` per interval (one row per parameter, m x len(time_s) - 1): dy1 = a dy0 + (da y0 + db),
    da = -a dt d_rate, db = -da target + (1 - a) d_target, from dy = 0 at the first sample and after every restart.
    Returns one row per parameter (m x len(time_s)), all solved at once (``linear_recurrence``'s ``_together``): they
    share the decays."""
    dt = np.maximum(np.diff(time_s), 0.0)
    efolds = np.asarray(rate_per_s, float) * dt
    a = np.exp(-efolds)
    da = -a * dt * np.asarray(d_rate, float)
    inhomogeneous = da * y[:-1] - da * target + (1.0 - a) * np.asarray(d_target, float)
    if restart is not None and restart.any():
        efolds[restart], inhomogeneous[:, restart] = _FORGET_EFOLDS, 0.0
    return linear_recurrence(efolds, inhomogeneous, 0.0)


def linear_recurrence(efolds: np.ndarray, b: np.ndarray, start: float) -> np.ndarray:
    """y with y[0] = start and y[i+1] = exp(-efolds[i]) y[i] + b[i] (efolds >= 0), vectorised; ``b`` may hold
    several series, one per row (m x len(efolds)), which share the decays: y then has one row per series, solved
    together (``_together``).

    With L the running sum of -efolds, y_i = exp(L_i - L_s) (y_s + sum_(s<=j<i) b_j exp(L_s - L_(j+1)))
    from any earlier row s. The rows are cut into chunks of at most _CHUNK_ROWS rows spanning less
    than _BLOCK_EFOLDS (so no exp() overflows); the sums run within every chunk at once (one row of
    a 2-D array each, so every sum starts from an exact zero), and a recurrence of the same form carries y
    from chunk to chunk (solved the same way when there are many chunks, so no Python loop per chunk).
    The chunks depend on ``efolds`` only (``_chunks``): a value and a derivative integrated alone with the same decays
    (a lag and its derivative in the time constant) share them.
    """
    b = np.asarray(b, float)
    if b.ndim > 1:
        return _together(np.asarray(efolds, float), b, start)
    c = _chunks(np.asarray(efolds, float))
    entering = np.zeros(len(c.first) * _CHUNK_ROWS)
    entering[c.place[1:]] = b * c.into_chunk
    entering[c.place[c.first]] = 0.0  # a chunk's first row gets its value from the chunk before
    within = np.cumsum(entering.reshape(len(c.first), _CHUNK_ROWS), axis=1).reshape(-1)[c.place]
    carried, into = within[c.last], b[c.first[1:] - 1]
    # the heads are a recurrence of the same form, one row per chunk: solved alike when that makes it much shorter
    # (not where fast decays cut the rows into chunks of one or two)
    if _CHUNK_ROWS < len(c.first) <= c.n // 4:
        heads = linear_recurrence(c.chunk_efolds, c.decay * carried[:-1] + into, start)
    else:
        heads = _heads(c, carried, into, start)
    return c.out_of_chunk * (heads[c.owner] + within)


def _together(efolds: np.ndarray, b: np.ndarray, start: float) -> np.ndarray:
    """``linear_recurrence`` of several series (rows of ``b``) at once, as the lower bidiagonal system it is
    (y[i+1] - exp(-efolds[i]) y[i] = b[i], unit diagonal) solved by LAPACK's triangular band solver (dtbtrs): plain
    forward substitution in compiled code, every series in one call, as exact as the chunked sums or more (a
    relaxation's four derivatives at 2,500 readings: 0.1 ms instead of 0.36 ms as four chunked series; at 10^5,
    4.3 ms instead of 8 ms; one series alone stays chunked: there the solver was no faster)."""
    n = len(efolds) + 1
    if len(b) == 0:
        return np.empty((0, n))
    band = np.empty((2, n))
    band[0] = 1.0
    band[1, :-1] = -np.exp(-efolds)
    band[1, -1] = 0.0
    right = np.empty((n, len(b)), order="F")
    right[0] = start
    right[1:] = b.T
    y, info = lapack.dtbtrs(band, right, uplo="L", diag="U", overwrite_b=1)
    if info != 0:  # pragma: no cover - a unit diagonal is never singular
        raise np.linalg.LinAlgError(f"dtbtrs failed (info {info})")
    return np.ascontiguousarray(y.T)


def _heads(c: _Chunks, carried: np.ndarray, into: np.ndarray, start: float) -> np.ndarray:
    """The value of one series at the head of every chunk, chunk after chunk (few chunks, or many short ones)."""
    heads = [float(start)]
    for g, (d, k, i) in enumerate(zip(c.decay_list, carried.tolist(), into.tolist(), strict=False)):
        heads.append(d * (heads[g] + k) + i)
    return np.asarray(heads)


@dataclass(frozen=True)
class _Chunks:
    """How ``linear_recurrence`` cuts its rows (``n`` of them), from the decays alone: each row's chunk (``owner``)
    and place in it (``pos``; ``place`` in the chunks laid end to end), each chunk's first and last row, the factors
    into and out of a chunk's sums, and the decay across each chunk."""

    n: int
    first: np.ndarray
    owner: np.ndarray
    pos: np.ndarray
    place: np.ndarray
    last: np.ndarray
    into_chunk: np.ndarray
    out_of_chunk: np.ndarray
    chunk_efolds: np.ndarray
    decay: np.ndarray
    decay_list: list[float]


#: The chunks cut lately, by the decays they were cut for (a model evaluation integrates one timeline with the same
#: decays for a value and a derivative, a lag's in its time constant; the heads' recurrence has decays of its own).
_recent_chunks: dict[bytes, _Chunks] = {}
_RECENT_CHUNKS = 4


def _chunks(efolds: np.ndarray) -> _Chunks:
    """The chunks of ``linear_recurrence`` for these decays (cut once for equal decays called for lately)."""
    key = efolds.tobytes()
    cached = _recent_chunks.get(key)
    if cached is not None:
        return cached
    n = len(efolds) + 1
    log_a = np.concatenate([[0.0], np.cumsum(-efolds)])
    level = np.floor(-log_a / _BLOCK_EFOLDS)
    first = np.flatnonzero(np.concatenate([[True], level[1:] != level[:-1]]))
    pos = np.arange(n) - np.repeat(first, np.diff(np.append(first, n)))
    first = np.flatnonzero(pos % _CHUNK_ROWS == 0)
    owner = np.repeat(np.arange(len(first)), np.diff(np.append(first, n)))
    pos = np.arange(n) - first[owner]
    ref = log_a[first][owner]
    chunk_efolds = log_a[first[:-1]] - log_a[first[1:]]
    decay = np.exp(-chunk_efolds)
    chunks = _Chunks(n, first, owner, pos, owner * _CHUNK_ROWS + pos, np.append(first[1:] - 1, n - 1),
                     np.exp(ref[1:] - log_a[1:]), np.exp(log_a - ref), chunk_efolds, decay, decay.tolist())
    if len(_recent_chunks) >= _RECENT_CHUNKS:
        _recent_chunks.clear()
    _recent_chunks[key] = chunks
    return chunks
