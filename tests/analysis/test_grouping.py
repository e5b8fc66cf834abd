"""Readings grouped by visit and thermal state; the intraclass correlation, Kish's design effect and
cluster-robust standard errors on data whose correlation is known."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ecds_lab.analysis.cluster_errors import cluster_robust_covariance
from ecds_lab.analysis.fitting import huber_residuals
from ecds_lab.analysis.grouping import (
    design_effect,
    intraclass_correlation,
    ramping,
    stretch_labels,
    temperature_rates_k_per_s,
    thermal_state_labels,
    visit_labels,
)
from ecds_lab.data.measurements import Measurements


def clustered_values(rho: float, size: int, clusters: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    labels = np.repeat(np.arange(clusters), size)
    shared = rng.normal(0, np.sqrt(rho), clusters)[labels]
    return shared + rng.normal(0, np.sqrt(1 - rho), len(labels)), labels


@pytest.mark.parametrize("rho", [0.0, 0.3, 0.8])
def test_the_intraclass_correlation_and_kish_design_effect_are_recovered(rho):
    values, labels = clustered_values(rho, 4, 2000)
    assert intraclass_correlation(values, labels) == pytest.approx(rho, abs=0.03)
    assert design_effect(values, labels) == pytest.approx(1 + 3 * rho, abs=0.1)


def test_singletons_have_no_design_effect():
    values = np.random.default_rng(1).normal(size=100)
    assert design_effect(values, np.arange(100)) == 1.0


def readings(x_mm, t_coil=None, t_target=None, time_s=None):
    x = np.asarray(x_mm, float) * 1e-3
    n = len(x)
    t = np.arange(n) * 10.0 if time_s is None else np.asarray(time_s, float)
    return Measurements(time_s=t, x_m=x, freq_hz=np.tile([500.0, 15000.0], n)[:n],
                        t_coil_c=np.full(n, 22.0) if t_coil is None else np.asarray(t_coil, float),
                        t_target_c=np.full(n, 22.0) if t_target is None else np.asarray(t_target, float),
                        ls_h=np.ones(n), rs_ohm=np.ones(n))


def test_a_visit_is_one_stop_of_the_slide_and_readings_in_air_are_each_their_own():
    data = readings([20, 20, 30, 30, 30, 20, 20, np.inf, np.inf])
    labels = visit_labels(data)
    assert labels.tolist() == [0, 0, 1, 1, 1, 2, 2, 3, 4]


def test_ramping_and_thermal_states_follow_the_temperatures():
    t = np.arange(200) * 60.0
    coil = np.r_[np.full(60, 22.0), 22 + 0.3 * np.arange(80), np.full(60, 46.0)]  # a 5 mK/s ramp
    data = readings(np.full(200, 30.0), t_coil=coil, time_s=t)
    moving = ramping(data)
    assert not moving[:50].any() and moving[70:130].all() and not moving[150:].any()
    states = thermal_state_labels(data)
    assert len(np.unique(states[:50])) == 1 and len(np.unique(states[150:])) == 1
    assert states[0] != states[-1]
    assert len(np.unique(states[70:130])) == 60  # every ramping reading its own state


def test_a_ramp_is_one_stretch_between_the_states_before_and_after_it():
    t = np.arange(200) * 60.0
    coil = np.r_[np.full(60, 22.0), 22 + 0.3 * np.arange(80), np.full(60, 46.0)]
    stretches = stretch_labels(readings(np.full(200, 30.0), t_coil=coil, time_s=t))
    steady, ramp, hot = stretches[:50], stretches[70:130], stretches[150:]
    assert len(set(steady)) == len(set(ramp)) == len(set(hot)) == 1  # not a stretch per ramping reading
    assert len({steady[0], ramp[0], hot[0]}) == 3


def test_the_rates_of_the_same_readings_are_found_once_and_new_temperatures_get_their_own():
    t = np.arange(100) * 60.0
    data = readings(np.full(100, 30.0), t_coil=22 + 0.3 * np.arange(100), time_s=t)
    rates = temperature_rates_k_per_s(data)
    assert temperature_rates_k_per_s(data) is rates and not rates.flags.writeable
    assert np.allclose(rates[10:90], 0.3 / 60.0)
    steady = replace(data, t_coil_c=np.full(100, 22.0))  # the same time column, a new coil column
    assert np.allclose(temperature_rates_k_per_s(steady), 0.0)
    assert temperature_rates_k_per_s(data) is rates


def test_cluster_robust_errors_match_the_naive_ones_for_independent_readings_and_grow_with_shared_errors():
    rng = np.random.default_rng(2)
    n = 4000
    x = np.column_stack([np.ones(n), rng.normal(size=n)])
    labels = np.repeat(np.arange(n // 4), 4)
    for shared_sigma, low, high in ((0.0, 0.9, 1.1), (2.0, 1.8, 2.6)):
        y = x @ [1.0, 2.0] + rng.normal(size=n) + rng.normal(0, shared_sigma, n // 4)[labels]
        beta = np.linalg.lstsq(x, y, rcond=None)[0]
        r = y - x @ beta
        naive = np.sqrt(np.diag(np.linalg.inv(x.T @ x) * (r @ r) / (n - 2)))
        robust = np.sqrt(np.diag(cluster_robust_covariance(-x, r, labels)))
        # the intercept shares the cluster error: its error grows by sqrt(1 + 3 rho) (rho = 0.8: 1.84);
        # the slope varies within clusters, so its error does not
        assert low < robust[0] / naive[0] < high
        assert 0.85 < robust[1] / naive[1] < 1.15


def test_huber_residuals_square_to_the_loss():
    r = np.array([-10.0, -1.0, 0.0, 0.5, 3.0])
    e = huber_residuals(r, 2.0)
    rho = np.where(np.abs(r) <= 2, r**2, 2 * 2 * np.abs(r) - 4)
    assert np.allclose(e**2, rho) and np.array_equal(np.sign(e), np.sign(r))
