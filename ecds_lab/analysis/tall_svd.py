"""The thin SVD of a tall Jacobian through its QR factorisation, for scipy's trust-region least squares.

scipy's ``least_squares(method="trf")`` takes, every iteration, ``U, s, V = svd(J, full_matrices=False)`` of the
(augmented) n x k Jacobian and uses U only as ``U.T.dot(f)``. LAPACK's gesdd forms the n x k U explicitly; for
n >> k that is most of its cost (128 ms of an SVD of 100,000 x 29 on one thread). Here J = Q R by Householder QR
(Q kept as its reflectors), R = U_r S V^T by the SVD of the small k x k R, so J = (Q U_r) S V^T: the same s and V,
and U^T f = U_r^T (Q^T f)[:k] with Q^T applied by its reflectors (62 ms in all). The factorisation is the one
gesdd itself starts a tall matrix with, so the solution agrees to rounding.

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

#: Matrices with fewer rows keep scipy's SVD (little to gain).
TALL_ROWS = 4000

_scipy_svd = scipy.linalg.svd
_lock = threading.Lock()
_users = 0


class _ImplicitU:
    """U = Q U_r of a tall matrix's thin SVD, Q held as its Householder reflectors: only ``U.T.dot(v)`` is offered
    (all the solver asks of U)."""

    def __init__(self, reflectors: np.ndarray, tau: np.ndarray, u_r: np.ndarray) -> None:
        self.reflectors, self.tau, self.u_r = reflectors, tau, u_r

    @property
    def T(self) -> _ImplicitUTransposed:
        return _ImplicitUTransposed(self)


class _ImplicitUTransposed:
    """U^T of an ``_ImplicitU``."""

    def __init__(self, u: _ImplicitU) -> None:
        self.u = u

    def dot(self, v: np.ndarray) -> np.ndarray:
        """U^T v = U_r^T (Q^T v)[:k]."""
        u = self.u
        k = u.u_r.shape[0]
        column = np.asfortranarray(np.asarray(v, float).reshape(-1, 1))
        qtv, _, info = lapack.dormqr("L", "T", u.reflectors, u.tau, column, lwork=max(64, k))
        if info != 0:
            raise np.linalg.LinAlgError(f"dormqr failed (info {info})")
        return u.u_r.T @ qtv[:k, 0]


def thin_svd(a: np.ndarray, full_matrices: bool = True, **options: Any) -> tuple[Any, np.ndarray, np.ndarray]:
    """``scipy.linalg.svd`` for the solver: a tall matrix's thin SVD through QR (U implicit, see module
    docstring); anything else is scipy's own."""
    a = np.asarray(a)
    if full_matrices or a.ndim != 2 or a.shape[0] < max(TALL_ROWS, 4 * a.shape[1]) or a.shape[1] == 0:
        return _scipy_svd(a, full_matrices=full_matrices, **options)
    (reflectors, tau), r = scipy.linalg.qr(a, mode="raw")  # a NaN or inf is refused, as by scipy's SVD
    u_r, s, vt = _scipy_svd(r, full_matrices=False, check_finite=False)
    return _ImplicitU(reflectors, tau, u_r), s, vt


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
