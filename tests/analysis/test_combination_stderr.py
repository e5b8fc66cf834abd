"""A combination of parameters the data determine though its parameters alone are open (fitting.combination_stderr):
finite, equal to what a fit of the combination alone gives, and continuous where a direction it does not use
crosses the covariance's rank threshold."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ecds_lab.analysis.fitting import _covariance, combination_stderr, fit
from ecds_lab.simulators.campaign import displacement_sweep
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab


@pytest.fixture(scope="module")
def template():
    """A real fit, whose Jacobian and residuals each case below replaces."""
    lab = SimulatedLab(LabConfig(physics="ecm", seed=3))
    return fit(displacement_sweep(lab, (20.0, 40.0, 60.0, 80.0), (15000.0,), repeats=2))


def _with_columns(template, columns: np.ndarray):
    """The template fit with three free parameters a, b, c whose Jacobian is ``columns`` (n x 3)."""
    n = columns.shape[0]
    residuals = np.random.default_rng(1).normal(0.0, 20.0, n)
    return replace(template, free_names=["a", "b", "c"], jacobian=columns, residuals_ppm=residuals,
                   covariance=_covariance(columns, residuals, n - 3), weights=None, loss_scale_ppm=None)


def _columns(tilt: float) -> np.ndarray:
    rng = np.random.default_rng(7)
    a = rng.normal(size=200)
    c = rng.normal(size=200)
    return np.column_stack([a, a + tilt * rng.normal(size=200), c])


def test_a_determined_sum_of_two_open_parameters_has_the_standard_error_of_the_sum(template):
    fitted = _with_columns(template, _columns(0.0))
    assert not math.isfinite(fitted.covariance[0, 0])  # each alone is open
    assert combination_stderr(fitted, {"a": 1.0}) == math.inf
    assert combination_stderr(fitted, {"a": 1.0, "b": -1.0}) == math.inf  # the open direction itself
    s = combination_stderr(fitted, {"a": 1.0, "b": 1.0})
    columns = _columns(0.0)
    s2 = float(fitted.residuals_ppm @ fitted.residuals_ppm) / (200 - 3)
    a_c = columns[:, [0, 2]]
    expected = math.sqrt(s2 * np.linalg.inv(a_c.T @ a_c)[0, 0])  # the sum as one parameter (a = b)
    assert s == pytest.approx(expected, rel=1e-9)
    assert combination_stderr(fitted, {"c": 1.0}) == pytest.approx(math.sqrt(fitted.covariance[2, 2]), rel=1e-9)


def test_the_sum_does_not_flip_where_the_open_direction_crosses_the_rank_threshold(template):
    """Columns a and a + t*noise: the difference's eigenvalue ~t^2 crosses the 1e-14 threshold near t = 1e-7;
    the per-parameter covariance flips from inf to finite there, the determined sum must not."""
    figures = [combination_stderr(_with_columns(template, _columns(t)), {"a": 1.0, "b": 1.0})
               for t in (0.0, 1e-9, 1e-8, 1e-7, 1e-6)]
    assert all(math.isfinite(s) for s in figures)
    assert max(figures) / min(figures) < 1.01
    per_parameter = [math.isfinite(_with_columns(template, _columns(t)).covariance[0, 0]) for t in (1e-9, 1e-6)]
    assert per_parameter == [False, True]  # the threshold the combination no longer depends on
