"""The error model on the faithful lab (physics: field): noise per phase, a heavy-tailed loss, readings
grouped by visit, positioning from revisits, and a warning when a declared figure is too large (issue 23)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import FAILING_RATIO, run_diagnosis
from ecds_lab.analysis.diagnosis.checks import MIN_CHI2_GAIN
from ecds_lab.analysis.fitting import fit, fit_model
from ecds_lab.analysis.grouping import visit_labels
from ecds_lab.analysis.noise import REGIMES, REPEATED, reading_groups
from ecds_lab.analysis.outliers import find_glitches
from ecds_lab.analysis.summary import fit_summary, format_fit_summary
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.simulators import campaign

#: The field solution's change of tau_T with x is real structure of the faithful lab (test_positioning_noise.py).
KNOWN = ["tau_displacement"]
RAMPING = REGIMES.index("heater ramping")


def heating_noisier(data, extra_ppm: float, seed: int = 5):
    """``data`` with extra Gaussian bridge noise on the readings taken while the coil's temperature changes
    by more than 2 mK/s (the heating ramps, judged from the data layer's own rate, not the analysis')."""
    heating = np.abs(data.coil_temperature_rate_k_per_s()) > 2e-3
    rng = np.random.default_rng(seed)
    return dataclasses.replace(data, ls_h=data.ls_h * (1 + extra_ppm * 1e-6 * rng.normal(size=len(data)) * heating)), \
        heating


def test_bridge_noise_larger_while_heating_is_found_per_phase_and_is_no_finding(field_campaign):
    data, heating = heating_noisier(field_campaign(), 80.0)
    assert heating.sum() > 100
    result = fit(data, KNOWN)
    noise = result.noise
    ramping = [c for c in noise.classes if c.regime == RAMPING]
    steady_air = [c for c in noise.classes if c.in_air and c.regime != RAMPING]
    assert ramping and steady_air
    assert min(c.sigma_ppm for c in ramping) > 2.5 * max(c.sigma_ppm for c in steady_air)
    sigma = noise.sigma_ppm(data)
    assert np.median(sigma[heating]) > 2.5 * np.median(sigma[~heating])
    every_third = np.arange(len(data)) % 3 == 0  # a subsample, as the search screens, gets the same noise
    assert np.mean(noise.sigma_ppm(data.select(every_third)) == sigma[every_third]) > 0.95
    # one number for all readings (the pooled figure) would call the residual a missing effect ...
    assert result.rms_ppm > FAILING_RATIO * noise.pooled_ppm
    # ... the noise per reading explains it: chi-square per reading about 1, the RMS at the typical noise
    chi2 = float(np.mean((result.residuals_ppm / sigma) ** 2))
    assert 0.6 < chi2 < 1.5
    assert result.rms_ppm < 1.2 * noise.ppm

    diagnosis = run_diagnosis(data)
    assert set(diagnosis.claimed) <= set(KNOWN), diagnosis.explanation
    assert "outside the library" not in diagnosis.explanation
    assert diagnosis.final.rmse_ppm < 1.2 * diagnosis.noise.ppm


def test_a_glitch_the_rules_miss_carries_no_evidence_under_the_heavy_tailed_loss(faithful_sweep_with):
    """A 2 % glitch on two successive readings of a sweep: each the other's neighbour deviating alike, so the rules
    take the pair for a run of structure and leave it in."""
    clean = faithful_sweep_with(1)
    rows = reading_groups(clean)[0][5:7]
    ls = clean.ls_h.copy()
    ls[rows] *= 1.02
    data = dataclasses.replace(clean, ls_h=ls)
    noise = fit(clean, KNOWN).noise
    base_plain = fit_model(SensorModel(None, KNOWN), data, noise=noise)
    assert not find_glitches(data, base_plain.residuals_ppm, noise.reading_sigma_ppm(data))[rows].any()

    def gain(robust: bool) -> float:
        base = fit_model(SensorModel(None, KNOWN), data, noise=noise, robust=robust, multistart=False)
        candidate = fit_model(SensorModel(None, [*KNOWN, "slide_backlash"]), data, start=base.values, noise=noise,
                              robust=robust, multistart=False, screening=True)
        eb, ec = base.effective_residuals_ppm, candidate.effective_residuals_ppm
        return float(eb @ eb - ec @ ec) / noise.ppm**2

    assert gain(robust=False) > 10 * MIN_CHI2_GAIN  # under squares the glitch alone makes a backlash
    assert gain(robust=True) < MIN_CHI2_GAIN / 5


def test_a_glitch_where_a_hot_run_begins_is_excluded_and_raises_no_alarm(study_campaign):
    """Validation study seed 2030 case 172 (two frequencies, up and down, target and coil heated; truth: glitches
    only): a 2.6 % glitch on the second reading of the repeat pair where the hot run begins (the slide arriving from
    above: a series of two readings) is excluded, and the faithful lab's tau(x) explains the rest; before, it bent
    the baseline by 2600 ppm at 20 mm and the diagnosis said "outside the library" (a false alarm)."""
    data = study_campaign(2030, 172)
    result = run_diagnosis(data)
    near = (data.x_mm == 20.0) & (data.freq_hz > 1000)  # the 15 kHz readings at 20 mm, the glitch among them
    glitch = int(np.argmax(np.where(near, np.abs(data.ls_h / np.median(data.ls_h[near]) - 1), 0.0)))
    assert abs(data.ls_h[glitch] / np.median(data.ls_h[near]) - 1) > 0.02
    assert glitch in [o.row for o in result.outliers], result.outliers
    assert "outside the library" not in result.explanation, result.explanation
    assert result.final.rmse_ppm <= FAILING_RATIO * result.noise_ppm, result.explanation


def test_readings_of_one_visit_sharing_a_position_error_have_a_design_effect(faithful_sweep_with):
    """Two readings at each of two frequencies per move: four readings share each move's position error."""
    shared = fit(faithful_sweep_with(1, repeatability_um=5.0), KNOWN)
    independent = fit(faithful_sweep_with(1), KNOWN)
    assert shared.noise.design_effect > 2.0
    assert independent.noise.design_effect < 1.3
    labels = visit_labels(shared_data := faithful_sweep_with(1, repeatability_um=5.0))
    assert np.median(np.bincount(labels[np.isfinite(shared_data.x_m)])) == 4
    # cluster-robust standard errors of the distance offset: larger than the naive ones when moves scatter
    shared_ratio = shared.clustered(labels).stderr["p1"] / shared.stderr["p1"]
    quiet = independent.clustered(visit_labels(faithful_sweep_with(1)))
    assert shared_ratio > 1.5
    assert shared_ratio > 2 * quiet.stderr["p1"] / independent.stderr["p1"]


def test_the_noise_at_the_target_is_not_the_structure_a_nine_position_sweep_leaves(field_config):
    """Nine positions, one reading each, no effect but the faithful lab's own: the baseline leaves ~200 ppm of
    tau(x) that a local quadratic over seven readings of a nine-point sweep cannot follow, so the noise about it
    reads 2.5-4x the bridge's at the target (47-68 ppm at 500 Hz beside 13-25 ppm from repeats in air). The
    diagnosis judges the final model with those figures found on it: the bridge's noise at the target about as in
    air (its noise does not change with the coil's place), and the final residual at the noise."""
    config = field_config(5)
    data = campaign.paper_campaign(config, seed=config.seed, positions_mm=tuple(np.linspace(20.0, 100.0, 9)),
                                   target_setpoints_c=(75, 130), coil_setpoints_c=(60.0, 100.0))
    result = run_diagnosis(data)
    assert set(result.claimed) <= {*KNOWN, "thermal_lag"}, result.explanation
    for f in (500.0, 15000.0):
        air = [c.sigma_ppm for c in result.noise.classes if c.freq_hz == f and c.in_air and c.method == REPEATED]
        target = [c.sigma_ppm for c in result.noise.classes if c.freq_hz == f and not c.in_air]
        assert air and target
        assert max(target) < 1.5 * max(air), (f, target, air)
    assert 0.85 < result.structure.noise_ratio < 1.2, result.structure


@pytest.fixture
def revisited(field_lab):
    """Three forward passes over the same distances at room temperature (two revisits of each), the lab's
    slide scattering 5 um per move (docs/simulated_lab.md, slide: repeatability)."""
    lab = field_lab(seed=11, slide={"repeatability": {"enabled": True, "sigma_um": 5.0}})
    positions = np.linspace(20.0, 60.0, 15)
    return campaign.displacement_sweep(lab, positions, directions=("forward", "forward", "forward"))


def test_positioning_is_estimated_from_revisits_in_one_direction(revisited):
    noise = fit(revisited, KNOWN).noise
    assert noise.positioning.declared_m == 0.0
    assert noise.positioning.dof >= 20
    assert noise.positioning.from_data_m == pytest.approx(5e-6, rel=0.35)
    assert noise.positioning.sigma_m == noise.positioning.from_data_m
    near, far = revisited.x_mm < 25, revisited.x_mm > 50
    share = noise.positioning_sigma_ppm(revisited)
    assert share[near].mean() > 2 * share[far].mean()  # x-dependent through the sensitivity


def test_the_declared_figure_is_a_prior_pooled_with_the_revisits(revisited):
    declared = dataclasses.replace(revisited, slide_repeatability_m=np.full(len(revisited), 20e-6))
    p = fit(declared, KNOWN).noise.positioning
    assert p.declared_m == 20e-6
    assert p.from_data_m < 10e-6 < p.sigma_m < 20e-6  # between the two, nearer the data (more dof)


@pytest.mark.parametrize(("declared_um", "warned"), [(20.0, True), (5.0, False)])
def test_a_declared_positioning_far_above_the_truth_is_warned_about(faithful_sweep_with, declared_um, warned):
    data = faithful_sweep_with(1, repeatability_um=5.0)
    data = dataclasses.replace(data, slide_repeatability_m=np.full(len(data), declared_um * 1e-6))
    noise = fit(data, KNOWN).noise
    assert bool(noise.warnings) == warned, noise.warnings
    if warned:
        assert "too large" in noise.warnings[0] and "20 um" in noise.warnings[0]
        assert f"warning: {noise.warnings[0]}" in format_fit_summary(fit_summary(data, KNOWN))


@pytest.mark.xfail(strict=True, reason="open: the robust start also flags row 66, one of a repeat pair beside a glitch "
                   "(-6.0 to -6.9 sigma against 5.5, with 150-190 ppm of structure left in the residual), with the "
                   "exact or the finite-difference Jacobian alike once the reweighting converges")
def test_a_robust_start_finds_exactly_the_glitches_of_a_one_frequency_campaign(field_lab, glitched):
    """Four 2 % glitches in a one-frequency sweep with repeated readings: a least-squares fit bends toward
    them and the rules then also flag readings beside them; the heavy-tailed fit does not bend."""
    data = campaign.displacement_sweep(field_lab(seed=4), np.linspace(20.0, 100.0, 30), frequencies_hz=(15000.0,),
                                       repeats=2)
    data, rows = glitched(data, 4, 2e4, seed=1)
    plain = fit(data, KNOWN)
    flagged_plain = set(np.flatnonzero(find_glitches(data, plain.residuals_ppm, plain.noise.reading_sigma_ppm(data))))
    robust = fit_model(SensorModel(None, KNOWN), data, start=plain.values, noise=plain.noise, robust=True)
    flagged = np.flatnonzero(find_glitches(data, robust.residuals_ppm, robust.noise.reading_sigma_ppm(data)))
    assert flagged.tolist() == rows
    assert flagged_plain > set(rows)  # what the plain fit's rules add beside the glitches
