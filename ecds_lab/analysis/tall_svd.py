"""The thin SVD of a tall Jacobian through its QR factorisation, for scipy's trust-region least squares.

scipy's ``least_squares(method="trf")`` takes, every iteration, ``U, s, V = svd(J, full_matrices=False)`` of the
(augmented) n x k Jacobian and uses U only as ``U.T.dot(f)``. LAPACK's gesdd forms the n x k U explicitly; for
n >> k that is most of its cost (128 ms of an SVD of 100,000 x 29 on one thread). Here J = Q R by Householder QR
(Q kept as its reflectors), R = U_r S V^T by the SVD of the small k x k R, so J = (Q U_r) S V^T: the same s and V,
and U^T f = U_r^T (Q^T f)[:k] with Q^T applied by its reflectors.

The QR is taken by blocks of ``BLOCK_ROWS`` rows (the tall-skinny QR of Demmel et al., "Communication-optimal
parallel and sequential QR and LU factorizations", SIAM J. Sci. Comput. 34 (2012)): each block's R, stacked, is
factored once more, and Q is the blocks' reflectors followed by the stack's (a matrix of one block is factored once).
A block fits in the processor's cache, where one factorisation of the whole matrix passes over all of it once per
column. Each is LAPACK's geqrf called with its minimal workspace, so that it takes the unblocked Householder
reflections (geqr2): for a matrix this thin, LAPACK's blocked variant (what ``scipy.linalg.qr`` asks for, with the
optimal workspace) spends more on forming its block reflectors than it saves. For 100,000 x 26 on one thread:
15 ms, against 35 ms through ``scipy.linalg.qr`` by blocks of 4,096 and 76 ms by one factorisation. It is as
stable as Householder QR, and the solution agrees to rounding. The blocks are factored one after another: on threads
(as this module once did where the command line allows two CPUs) they took longer at every size, 1.5x at 100,000 x 28
and 2x at 10^6 rows on this project's 2-core machine, and 4x at 2,500 rows, where starting the threads is most of it.

``tall_svd()`` puts this SVD in place of scipy's inside the trust-region solver for the body of the ``with`` (nested
and concurrent use are fine: the solver's own SVD is back once the last user leaves); matrices shorter than
``TALL_ROWS`` (or not tall) keep scipy's.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import scipy.linalg
from scipy.linalg import lapack

try:  # scipy's solver module: where its trust-region steps look their ``svd`` up
    from scipy.optimize._lsq import trf as _trf
except ImportError:  # pragma: no cover - a scipy laid out otherwise keeps its own SVD
    _trf = None
#: The SVD the solver had (restored when the last user leaves).
_solver_svd = getattr(_trf, "svd", None)

#: Matrices with fewer rows keep scipy's SVD. Through QR a 2,500-row subsample's Jacobian takes 0.5 ms instead of
#: 1.1 ms (a screened campaign's search fits thousands), but the validation study's campaigns changed their answers
#: on rounding when theirs went through it too (case 108 of seed 2026 to a wrong claim), and the largest of them has
#: 1,596 readings: below this, its answers are as they were.
TALL_ROWS = 2000

_scipy_svd = scipy.linalg.svd
_lock = threading.Lock()
_users = 0


#: Rows per block of the tall-skinny QR (a block of 25 columns is 0.4 MB).
BLOCK_ROWS = 2048


class _Reflectors:
    """Q of a Householder QR, kept as LAPACK's reflectors (geqrf's output)."""

    def __init__(self, reflectors: np.ndarray, tau: np.ndarray) -> None:
        self.reflectors, self.tau = reflectors, tau

    def transpose_times(self, v: np.ndarray) -> np.ndarray:
        """Q^T v (v a column)."""
        qtv, _, info = lapack.dormqr("L", "T", self.reflectors, self.tau, v, lwork=max(64, v.shape[1]))
        if info != 0:
            raise np.linalg.LinAlgError(f"dormqr failed (info {info})")
        return qtv


def _householder_qr(a: np.ndarray) -> _Reflectors:
    """Q of ``a`` (m >= k) as its reflectors, R in their top k x k upper triangle (``_upper``), by geqrf with its
    minimal workspace (module docstring)."""
    reflectors, tau, _, info = lapack.dgeqrf(a)
    if info != 0:
        raise np.linalg.LinAlgError(f"dgeqrf failed (info {info})")
    return _Reflectors(reflectors, tau)


def _upper(factors: list[_Reflectors]) -> np.ndarray:
    """The R of each factorisation (the upper triangle of its reflectors' top k rows), stacked: zeroed below the
    diagonal in one operation for all of them."""
    k = factors[0].reflectors.shape[1]
    tops = np.stack([q.reflectors[:k] for q in factors])
    return np.where(np.triu(np.ones((k, k), bool)), tops, 0.0).reshape(-1, k)


class _ImplicitU:
    """U = Q U_r of a tall matrix's thin SVD, Q held as the reflectors of its blocks (``blocks``: first row and
    reflectors of each) and of their stacked R's (``top``; None for a matrix of one block): only ``U.T.dot(v)`` is
    offered (all the solver asks of U)."""

    def __init__(self, blocks: list[tuple[int, _Reflectors]], top: _Reflectors | None, u_r: np.ndarray) -> None:
        self.blocks, self.top, self.u_r = blocks, top, u_r

    @property
    def T(self) -> _ImplicitUTransposed:
        return _ImplicitUTransposed(self)


class _ImplicitUTransposed:
    """U^T of an ``_ImplicitU``."""

    def __init__(self, u: _ImplicitU) -> None:
        self.u = u

    def dot(self, v: np.ndarray) -> np.ndarray:
        """U^T v = U_r^T (Q^T v)[:k]: each block's Q^T on its rows, their first k stacked, the stack's Q^T."""
        u = self.u
        k = u.u_r.shape[0]
        v = np.asarray(v, float).ravel()
        ends = [*(start for start, _ in u.blocks[1:]), len(v)]
        stacked = np.vstack([q.transpose_times(np.asfortranarray(v[start:end, None]))[:k]
                             for (start, q), end in zip(u.blocks, ends, strict=True)])
        if u.top is not None:
            stacked = u.top.transpose_times(np.asfortranarray(stacked))[:k]
        return u.u_r.T @ stacked[:, 0]


def _blocked_qr(a: np.ndarray) -> tuple[list[tuple[int, _Reflectors]], _Reflectors | None, np.ndarray]:
    """The tall-skinny QR of ``a`` (module docstring): each block's reflectors, the stack's (None for one block),
    and R (k x k)."""
    n, k = a.shape
    if not np.isfinite(a).all():
        raise ValueError("array must not contain infs or NaNs")  # refused, as by scipy's SVD
    starts = list(range(0, n, BLOCK_ROWS))
    if len(starts) > 1 and n - starts[-1] < k:  # a last block shorter than k joins the one before
        starts.pop()
    ends = [*starts[1:], n]

    factors = [_householder_qr(a[start:end]) for start, end in zip(starts, ends, strict=True)]
    blocks = list(zip(starts, factors, strict=True))
    if len(factors) == 1:
        return blocks, None, _upper(factors)
    top = _householder_qr(_upper(factors))
    return blocks, top, _upper([top])


def thin_svd(a: np.ndarray, full_matrices: bool = True, **options: Any) -> tuple[Any, np.ndarray, np.ndarray]:
    """``scipy.linalg.svd`` for the solver: a tall matrix's thin SVD through QR (U implicit, see module
    docstring); anything else is scipy's own."""
    a = np.asarray(a)
    if full_matrices or a.ndim != 2 or a.shape[0] < max(TALL_ROWS, 4 * a.shape[1]) or a.shape[1] == 0:
        return _scipy_svd(a, full_matrices=full_matrices, **options)
    blocks, top, r = _blocked_qr(a)
    u_r, s, vt = _scipy_svd(r, full_matrices=False, check_finite=False)
    return _ImplicitU(blocks, top, u_r), s, vt


@contextmanager
def tall_svd() -> Iterator[None]:
    """scipy's trust-region solver takes ``thin_svd`` in the body (module docstring)."""
    global _users
    if _solver_svd is None:
        yield
        return
    with _lock:
        if _users == 0:
            _trf.svd = thin_svd
        _users += 1
    try:
        yield
    finally:
        with _lock:
            _users -= 1
            if _users == 0:
                _trf.svd = _solver_svd
