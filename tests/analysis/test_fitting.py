"""Fitting the baseline model to simulated campaigns: recovery, uncertainties, residuals, robustness."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from ecds_lab.analysis import fitting
from ecds_lab.analysis.fitting import fit, fit_model
from ecds_lab.analysis.noise import REPEATED, estimate_noise
from ecds_lab.model.parameters import values_of
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.simulators.campaign import displacement_sweep, paper_campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

NOISE_PPM = LabConfig().noise.bridge_relative["slow"] * 1e6


def _truth(config: LabConfig) -> dict[str, float]:
    return {"L0": config.sensor.inductance_h, "alpha": config.alpha, "beta": config.beta_per_k2,
            "tau_t": config.tau_t, "p1": 0.0, "p2": 1.0, "p3": 1.0, "p4": 0.0, "C_p": config.sensor.capacitance_f}


@pytest.fixture(scope="module")
def campaign():
    return paper_campaign(LabConfig(), seed=11)


@pytest.fixture(scope="module")
def baseline_fit(campaign):
    return fit(campaign)


def test_baseline_fit_recovers_the_simulated_parameters(baseline_fit):
    truth = _truth(LabConfig())
    assert baseline_fit.success
    assert set(baseline_fit.free_names) == set(truth)
    for name, value in truth.items():
        err = baseline_fit.stderr[name]
        assert np.isfinite(err) and err > 0, name
        assert abs(baseline_fit.values[name] - value) <= 3 * err, (name, baseline_fit.values[name], value, err)
    # the uncertainties are small enough for the comparison to mean something
    assert baseline_fit.stderr["L0"] < 1e-5 * truth["L0"]
    assert baseline_fit.stderr["alpha"] < 0.02 * truth["alpha"]
    assert baseline_fit.stderr["beta"] < 0.2 * truth["beta"]
    assert baseline_fit.stderr["tau_t"] < 1e-3 * truth["tau_t"]
    assert baseline_fit.stderr["C_p"] < 1e-3 * truth["C_p"]


def test_residuals_are_the_simulated_noise(baseline_fit, campaign):
    assert abs(baseline_fit.rms_ppm / NOISE_PPM - 1) < 0.2
    assert baseline_fit.dof == len(campaign) - len(baseline_fit.free_names)
    recomputed = (campaign.ls_h / baseline_fit.predict(campaign) - 1) * 1e6
    np.testing.assert_allclose(baseline_fit.residuals_ppm, recomputed, atol=1e-6)
    rss = float(np.sum(recomputed**2))
    n, k = len(campaign), len(baseline_fit.free_names)
    assert baseline_fit.bic == pytest.approx(n * np.log(rss / n) + k * np.log(n), rel=1e-9)


def test_only_the_sensor_given_loss_is_fixed_on_a_full_campaign(baseline_fit):
    assert set(baseline_fit.fixed) == {"R_p"}
    table = baseline_fit.params_table()
    json.dumps(table, allow_nan=False)
    assert table["L0"]["unit"] == "H" and table["R_p"]["stderr"] is None


def test_a_fit_carries_the_noise_its_repeated_readings_show():
    data = displacement_sweep(SimulatedLab(LabConfig(seed=4)), repeats=4)
    result = fit(data)
    assert result.noise.method == REPEATED
    assert abs(result.noise_ppm / NOISE_PPM - 1) < 0.1
    assert result.noise == estimate_noise(data, result.residuals_ppm)
    assert estimate_noise(data.select(np.arange(5)), np.zeros(5)).method != REPEATED


def test_single_frequency_room_sweep_fixes_and_reports_what_it_cannot_determine():
    data = displacement_sweep(SimulatedLab(LabConfig(seed=5)), frequencies_hz=(15000.0,), air_repeats=5)
    result = fit(data)
    assert {"alpha", "beta", "C_p", "tau_t", "R_p"} == set(result.fixed)
    assert result.parameter("alpha").value == 0.0 and result.parameter("tau_t").value == LabConfig().tau_t
    assert abs(result.rms_ppm / NOISE_PPM - 1) < 0.25


def test_caller_fixed_values_are_held():
    data = displacement_sweep(SimulatedLab(LabConfig(seed=6)), frequencies_hz=(15000.0,), air_repeats=5)
    result = fit(data, fixed={"p2": 1.0})
    assert result.parameter("p2").fixed and result.parameter("p2").value == 1.0
    assert result.fixed["p2"] == "fixed by the caller"


@pytest.mark.parametrize("offsets", [{"p1": 0.015}, {"p1": 0.02, "p2": 1.5}, {"tau_t": 15e-6, "p3": 1.1}])
def test_fit_finds_parameters_far_from_the_nominal_start(campaign, offsets):
    model = SensorModel()
    truth = values_of(model.parameters()) | {"alpha": 3e-5, "beta": -1e-8, "C_p": 55e-12} | offsets
    rng = np.random.default_rng(2)
    data = replace(campaign, ls_h=model.predict(campaign, truth) * (1 + 20e-6 * rng.standard_normal(len(campaign))))
    result = fit_model(model, data)
    assert abs(result.rms_ppm / NOISE_PPM - 1) < 0.2
    for name in result.free_names:
        assert abs(result.values[name] - truth[name]) <= 4 * result.stderr[name], name


def test_a_large_campaign_tries_its_restarts_on_a_subsample_and_still_finds_them(campaign, monkeypatch):
    """Above ``_SEARCH_ROWS`` readings the alternative starts are solved on a subsample and the winner polished on
    every reading (lowered here so the test campaign counts as large): the same parameters are found."""
    monkeypatch.setattr(fitting, "_SEARCH_ROWS", len(campaign) // 3)
    model = SensorModel()
    truth = values_of(model.parameters()) | {"alpha": 3e-5, "beta": -1e-8, "C_p": 55e-12, "p1": 0.02, "p2": 1.5}
    rng = np.random.default_rng(2)
    data = replace(campaign, ls_h=model.predict(campaign, truth) * (1 + 20e-6 * rng.standard_normal(len(campaign))))
    result = fit_model(model, data)
    assert result.starts > 2  # the restarts ran (on the subsample)
    assert abs(result.rms_ppm / NOISE_PPM - 1) < 0.2
    for name in result.free_names:
        assert abs(result.values[name] - truth[name]) <= 4 * result.stderr[name], name


def polished_and_plain(campaign, offset: float, noise_ppm: float | None = None):
    """A drying that is absent in truth (conductance 0, every water molecule bound: both on their bounds), fitted by
    a screening fit and a screening polish (told ``noise_ppm``) from a start ``offset`` away in L0, alpha and p1 (1:
    near the answer)."""
    model = SensorModel(None, ["parasitic_capacitance"])
    truth = values_of(model.parameters()) | {"moist_dC": 2e-13, "moist_dG": 0.0, "bound_share": 1.0}
    rng = np.random.default_rng(3)
    data = replace(campaign, ls_h=model.predict(campaign, truth) * (1 + 20e-6 * rng.standard_normal(len(campaign))))
    start = truth | {"L0": truth["L0"] * (1 + offset * 3e-5), "alpha": truth["alpha"] + offset * 2e-6,
                     "p1": truth["p1"] + offset * 2e-5}
    return (fit_model(model, data, start=start, multistart=False, screening=True, polish=True, noise_ppm=noise_ppm),
            fit_model(model, data, start=start, multistart=False, screening=True))


def test_a_polish_from_a_nearby_start_with_parameters_on_their_bounds_ends_at_the_same_fit_in_fewer_evaluations(
        campaign):
    """The polish does not first grow a trust region 1e-9 from the drying's bounds."""
    polished, plain = polished_and_plain(campaign, 1.0)
    assert polished.nfev < 0.75 * plain.nfev, (polished.nfev, plain.nfev)
    assert polished.rms_ppm == pytest.approx(plain.rms_ppm, rel=1e-6)
    for name in ("L0", "alpha", "p1", "moist_dC"):
        assert abs(polished.values[name] - plain.values[name]) < 0.1 * plain.stderr[name], name


def test_a_screening_polish_stops_at_its_budget_of_evaluations(campaign, monkeypatch):
    """A polish starts near the answer: after ``_POLISH_BUDGET`` evaluations per parameter (and one) it stops, where a
    plain screening fit from the same start goes on (lowered to 1 here, so this start runs into it)."""
    monkeypatch.setattr(fitting, "_POLISH_BUDGET", 1)
    polished, plain = polished_and_plain(campaign, 10.0)
    budget = len(polished.free_names) + 1
    assert polished.nfev <= budget < plain.nfev, (polished.nfev, budget, plain.nfev)
    assert polished.rms_ppm == pytest.approx(plain.rms_ppm, rel=1e-3)


def test_a_fit_given_a_budget_stops_after_that_many_evaluations_per_parameter(campaign):
    """``budget`` (a repolish's scout): evaluations per free parameter and one, where the same fit without it goes
    on."""
    model = SensorModel()
    start = values_of(model.parameters()) | {"alpha": 3e-5, "p1": 0.02, "p2": 1.5}
    bounded = fit_model(model, campaign, start=start, multistart=False, screening=True, budget=1)
    plain = fit_model(model, campaign, start=start, multistart=False, screening=True)
    assert bounded.nfev <= len(bounded.free_names) + 1 < plain.nfev, (bounded.nfev, plain.nfev)
    assert plain.rms_ppm < bounded.rms_ppm


def test_a_polish_told_the_noise_stops_at_a_step_that_gains_a_negligible_chi_square(campaign, monkeypatch):
    """Told the reading noise, a polish stops at the first step gaining less than ``NEGLIGIBLE_CHI2`` in its
    variance: never later than without it, and where it leaves the fit less than that is left to gain. Raised
    here until it bites, it stops sooner than without it."""
    polished, _ = polished_and_plain(campaign, 10.0)
    told = polished_and_plain(campaign, 10.0, NOISE_PPM)[0]
    chi2 = (told.residuals_ppm @ told.residuals_ppm - polished.residuals_ppm @ polished.residuals_ppm) / NOISE_PPM**2
    assert told.nfev <= polished.nfev and abs(chi2) < 1.0, (told.nfev, polished.nfev, chi2)
    monkeypatch.setattr(fitting, "NEGLIGIBLE_CHI2", 1e3)
    assert polished_and_plain(campaign, 10.0, NOISE_PPM)[0].nfev < polished.nfev


def test_a_solution_evaluated_on_other_readings_carries_their_residuals_and_its_own_noise(baseline_fit, campaign):
    half = campaign.select(np.arange(len(campaign)) % 2 == 0)
    noise = baseline_fit.noise
    other = fitting.evaluated(baseline_fit, half)
    assert other.values == baseline_fit.values and other.n == len(half) and other.nfev == 0
    np.testing.assert_allclose(other.residuals_ppm, (half.ls_h / baseline_fit.predict(half) - 1) * 1e6)
    assert other.noise is noise
