"""The tall Jacobian's thin SVD through QR (``analysis.tall_svd``) gives scipy's singular values, right vectors and
U^T f, and a fit through it the same solution."""

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import least_squares

from ecds_lab.analysis import tall_svd


@pytest.mark.parametrize("rows", [
    6000,  # several blocks
    3 * tall_svd.BLOCK_ROWS + 5,  # a last block shorter than the matrix is wide joins the one before
])
def test_thin_svd_agrees_with_scipy_on_a_tall_matrix(rows):
    rng = np.random.default_rng(3)
    a = rng.normal(size=(rows, 7)) * np.logspace(0, 6, 7)  # columns of very different scales, as a Jacobian's
    f = rng.normal(size=rows)
    u, s, vt = scipy.linalg.svd(a, full_matrices=False)
    implicit_u, s2, vt2 = tall_svd.thin_svd(a, full_matrices=False)
    np.testing.assert_allclose(s2, s, rtol=1e-12)
    # singular vectors are defined up to a sign shared by U's and V's column: compare the products
    signs = np.sign(np.sum(vt * vt2, axis=1))
    np.testing.assert_allclose(vt2 * signs[:, None], vt, atol=1e-10)
    np.testing.assert_allclose(implicit_u.T.dot(f) * signs, u.T @ f, rtol=1e-9, atol=1e-12)


def test_short_or_full_matrices_keep_scipys_svd():
    a = np.arange(12.0).reshape(4, 3)
    u, _, vt = tall_svd.thin_svd(a, full_matrices=False)
    assert isinstance(u, np.ndarray) and u.shape == (4, 3) and vt.shape == (3, 3)


def test_a_fit_through_it_reaches_scipys_solution_and_the_solver_gets_its_svd_back():
    t = np.linspace(0, 10, 20_000)
    rng = np.random.default_rng(1)
    y = 2.0 * np.exp(-t / 3.0) + 0.5 * np.sin(1.3 * t) + rng.normal(scale=1e-3, size=t.size)

    def residuals(p):
        return p[0] * np.exp(-t / p[1]) + p[2] * np.sin(p[3] * t) - y

    start, bounds = [1.0, 1.0, 0.1, 1.25], ([0, 0.1, -5, 0.5], [10, 100, 5, 2.0])
    plain = least_squares(residuals, start, bounds=bounds, method="trf")
    from scipy.optimize._lsq import trf
    before = trf.svd
    with tall_svd.tall_svd():
        assert trf.svd is tall_svd.thin_svd
        through_qr = least_squares(residuals, start, bounds=bounds, method="trf")
    assert trf.svd is before
    np.testing.assert_allclose(through_qr.x, plain.x, rtol=1e-8)
    assert through_qr.nfev == plain.nfev


def test_a_matrix_with_a_nan_is_refused_as_by_scipys_svd():
    a = np.ones((5000, 3))
    a[10, 1] = np.nan
    with pytest.raises(ValueError):
        tall_svd.thin_svd(a, full_matrices=False)
