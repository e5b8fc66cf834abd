"""The noise estimate's own uncertainty: its degrees of freedom, and the margin a chi-square test of means leaves
for it (analysis/noise_margin.py, docs/diagnosis.md "Margin for the noise's uncertainty")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ecds_lab.analysis.noise import (
    MAD_EFFICIENCY,
    NOISE_SMOOTH_FACTOR,
    combined_dof,
    local_quadratic,
    remainder_dof_per_reading,
)
from ecds_lab.analysis.noise_margin import loadings, null_moments, significance

RUNS = 3000


def _dof_seen(variances: np.ndarray) -> float:
    """Degrees of freedom a set of variance estimates of one true variance shows: 2 / relative variance."""
    return 2.0 / float(np.var(variances / variances.mean()))


def test_a_mad_of_repeat_differences_has_the_stated_degrees_of_freedom():
    rng = np.random.default_rng(1)
    n = 60
    d = rng.normal(size=(RUNS, n)) * math.sqrt(2.0)
    mad = np.median(np.abs(d - np.median(d, axis=1, keepdims=True)), axis=1)
    variances = (1.4826 * mad / math.sqrt(2.0)) ** 2
    assert _dof_seen(variances) == pytest.approx(MAD_EFFICIENCY * n, rel=0.15)


def test_remainders_about_the_smooth_have_the_stated_degrees_of_freedom():
    """Neighbouring remainders share their smooth: fewer degrees of freedom per reading than independent values."""
    rng = np.random.default_rng(2)
    n = 140
    variances = []
    for _ in range(RUNS):
        u = (v := rng.normal(size=n)) - local_quadratic(v, 7)
        variances.append((np.median(np.abs(u - np.median(u))) / NOISE_SMOOTH_FACTOR / 0.6745) ** 2)
    assert remainder_dof_per_reading() < MAD_EFFICIENCY
    assert _dof_seen(np.array(variances)) == pytest.approx(remainder_dof_per_reading() * n, rel=0.2)


def test_combined_degrees_of_freedom_follow_welch_satterthwaite():
    assert combined_dof([1.0], [12.0]) == pytest.approx(12.0)
    assert combined_dof([1.0, 1.0], [10.0, 10.0]) == pytest.approx(20.0)
    assert combined_dof([1.0, 1.0], [10.0, math.inf]) == pytest.approx(40.0)  # a known part halves the spread


@pytest.mark.parametrize("dof", [8.0, 30.0])
def test_pure_noise_judged_against_a_noise_from_few_readings_makes_no_structure(dof):
    """300 states of 2 readings of pure noise, half read against one estimated noise and half against another,
    each from ``dof`` degrees of freedom. Taken as exact, the noise's own scatter alone puts the bin-means statistic
    many of its standard deviations beyond chance (a figure that came out low by chance is a "finding"); with the
    margin it has about a standard normal's spread, and the structure test's 8 is out of reach but for the
    inverse chi-square's heavy tail at very few dof (8 dof: 0.07 % in 20,000 draws, 30 dof: none)."""
    rng = np.random.default_rng(3)
    states, per_state = 300, 2
    labels = np.repeat(np.arange(states), per_state)
    half = (labels >= states // 2).astype(int)
    shares = np.column_stack([half == 0, half == 1]).astype(float)
    loads, estimates = loadings(labels, shares), np.full(2, dof)
    mean, sd = null_moments(states, loads, estimates)
    plain, margin = [], []
    for _ in range(RUNS):
        variance = rng.chisquare(dof, size=2) / dof  # each estimate's ratio to the true variance
        z = rng.normal(size=len(labels)) / np.sqrt(variance[half])
        energy = float(np.sum(np.bincount(labels, weights=z) ** 2 / per_state))
        plain.append((energy - states) / math.sqrt(2 * states))
        margin.append(significance(energy, states, loads, estimates))
    plain, margin = np.array(plain), np.array(margin)
    assert abs(float(np.median(margin))) < 0.3
    assert float(np.std(margin)) == pytest.approx(1.0, abs=0.15)
    assert np.mean(margin > 3.0) < 0.025
    assert np.mean(plain > 3.0) > 0.15
    # the structure test's 8 sd: a noise figure's own scatter crosses it often without the margin, not with it
    assert np.mean(margin > 8.0) < 0.002
    assert np.mean(plain > 8.0) > (0.1 if dof < 10 else 0.01)
    assert sd > 2 * math.sqrt(2 * states) and mean > states


def test_a_known_noise_leaves_the_chi_square_as_it_was():
    labels = np.repeat(np.arange(50), 3)
    shares = np.ones((len(labels), 1))
    known = np.array([math.inf])
    assert null_moments(50, loadings(labels, shares), known) == pytest.approx((50.0, 10.0))
    assert loadings(labels, shares) == pytest.approx([50.0])
    for statistic in (30.0, 50.0, 90.0, 400.0):
        assert significance(statistic, 50, loadings(labels, shares), known) == pytest.approx((statistic - 50) / 10)
