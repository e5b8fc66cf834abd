"""The diagnosis on campaigns made for each way it used to fail (issue 15, classes 1-6), built with
the simulated lab's campaign functions, plus the honest-verdict cases and the user-effect walkthrough."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from ecds_lab.analysis.associations import residual_associations
from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.analysis.fitting import fit
from ecds_lab.cli import main
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import library
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

POSITIONS_MM = tuple(float(x) for x in np.linspace(20.0, 100.0, 16))
EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "examples" / "metal_object.py"


def lab_with(**effects: dict) -> SimulatedLab:
    return SimulatedLab(LabConfig(effects={name: {"enabled": True, **size} for name, size in effects.items()}, seed=3))


# -- class 1: glitches ------------------------------------------------------------------------------
def test_glitches_do_not_hide_a_real_backlash(glitched):
    lab = lab_with(slide_backlash={"backlash_um": 30.0})
    data = campaign.displacement_sweep(lab, campaign.PAPER_POSITIONS_MM, (15000.0,))
    data = Measurements.concatenate([data, campaign.displacement_sweep(lab, campaign.PAPER_POSITIONS_MM,
                                                                       (15000.0,))])
    data, rows = glitched(data, 2, 3000.0, seed=1)
    result = run_diagnosis(data)
    assert [o.row for o in result.outliers] == rows
    assert all(abs(o.residual_sigma) > 10 and "glitch" in o.reason for o in result.outliers)
    assert result.claimed == ["slide_backlash"], [(c.effect, c.rejected) for c in result.candidates]
    backlash = result.final.fit.values["backlash"]
    assert backlash == pytest.approx(30e-6, rel=0.25)


def test_a_campaign_with_no_effect_and_glitches_is_adequate(campaign_with, glitched):
    data, rows = glitched(campaign_with(), 5, -2500.0, seed=2)
    report = run_diagnosis(data).to_json()
    assert report["verdict"] == "adequate", report["explanation"]
    assert [o["row"] for o in report["outliers"]] == rows
    assert all(o["residual_sigma"] < -10 for o in report["outliers"])
    assert "outside the library" not in report["explanation"]


# -- class 2: a claim must pass its checks ---------------------------------------------------------
def test_no_claim_fails_its_checks_and_nested_fits_never_end_worse(campaign_with):
    result = run_diagnosis(campaign_with("target_bending", "slide_backlash"))
    for before, step in zip(result.steps, result.steps[1:], strict=False):
        claimed = next(c for c in before.candidates if c.effect == step.effects[-1])
        extra = {"beyond_drift"} if claimed.effect_object.drift_leaves_it else set()
        assert claimed.passes and set(claimed.checks) == {"evidence", "identifiable", "plausible", "held_out", *extra}
        assert claimed.cv_rmse_ppm < claimed.base_cv_rmse_ppm
    for step in result.steps:
        for candidate in step.candidates:
            assert candidate.rmse_ppm <= step.rmse_ppm * (1 + 1e-9) or candidate.not_better


def test_an_implausibly_large_bending_is_not_claimed():
    """A shift of 300 um/K (33 mm over 110 K) is no plate bending: the residual is left outside the library."""
    lab = lab_with(target_bending={"shift_um_per_k": 300.0})
    room = campaign.displacement_sweep(lab, POSITIONS_MM)
    hot = campaign.target_heating(lab, (60, 90), positions_mm=tuple(x for x in POSITIONS_MM if x >= 60))
    result = run_diagnosis(Measurements.concatenate([room, hot]))
    assert "target_bending" not in result.claimed
    bending = next(c for c in result.candidates if c.effect == "target_bending")
    assert not bending.passes


# -- class 3: one frequency ------------------------------------------------------------------------
def one_frequency_target_heating(size_um_per_k: float | None, positions=(30, 50, 70, 100), repeats=3,
                                 setpoints=(120,)) -> Measurements:
    effects = {"target_bending": {"shift_um_per_k": size_um_per_k}} if size_um_per_k else \
        {"target_tau_temperature": {}}
    lab = lab_with(**effects)
    room = campaign.displacement_sweep(lab, positions, (15000.0,), directions=("forward",), repeats=repeats)
    hot = campaign.target_heating(lab, setpoints, positions_mm=positions, frequencies_hz=(15000.0,),
                                  directions=("forward",), repeats=repeats)
    return Measurements.concatenate([room, hot])


def test_one_frequency_conductivity_change_is_not_taken_for_bending():
    data = one_frequency_target_heating(None, positions=POSITIONS_MM, repeats=1, setpoints=(60, 100, 140))
    result = run_diagnosis(data)
    assert "target_bending" not in result.claimed[:1]
    assert result.claimed[:1] == ["target_tau_temperature"] or any(
        "target_tau_temperature" in group for group in result.alternatives)


def test_two_indistinguishable_effects_are_both_named_with_a_measurement_to_separate_them():
    result = run_diagnosis(one_frequency_target_heating(0.5))
    assert result.verdict == "inconclusive", result.explanation
    assert result.claimed == []
    assert any({"target_bending", "target_tau_temperature"} <= set(group) for group in result.alternatives)
    assert any("500 Hz" in s for s in result.suggested_measurements)
    report = result.to_json()
    assert report["alternatives"] and report["suggested_measurements"]
    json.dumps(report)


# -- class 4: masking, a three-part truth ------------------------------------------------------------
def test_a_three_part_truth_is_found_step_by_step(campaign_with):
    result = run_diagnosis(campaign_with("target_bending", "slide_backlash", "thermal_lag"))
    assert set(result.claimed) == {"target_bending", "slide_backlash", "thermal_lag"}, result.explanation
    assert result.final.rmse_ppm <= 1.5 * result.noise_ppm
    report = result.to_json()
    assert [len(s["effects"]) for s in report["steps"]] == [0, 1, 2, 3]
    rms = [s["rmse_ppm"] for s in report["steps"]]
    assert rms == sorted(rms, reverse=True)
    first, last = report["steps"][0], report["steps"][-1]
    if first["position_error"]["status"] == "model fails here":  # no length for a failing model (issue 24.2)
        assert last["position_error"]["status"] == "valid"
    else:
        assert last["position_error_mm"] < 0.6 * first["position_error_mm"]


# -- class 5: where the residual lives, phases and noise ---------------------------------------------
def test_associations_credit_the_state_not_the_phase(campaign_with):
    """Target bending lives in x and target temperature; time and coil rate only mark the phases."""
    data = campaign_with("target_bending")
    base = fit(data, [])
    ranked = [a.variable for a in residual_associations(data, base.residuals_ppm, 20.0)]
    assert ranked[0] in ("t_target_c", "x_mm"), ranked
    assert ranked.index("time_s") > ranked.index("t_target_c")
    assert ranked.index("coil_rate_k_per_min") > ranked.index("t_target_c")


def test_the_noise_is_not_inflated_by_structure(campaign_with):
    result = run_diagnosis(campaign_with("target_tau_temperature"))
    assert result.noise_ppm == pytest.approx(20.0, rel=0.2)  # LabConfig's slow-speed bridge noise


# -- class 6: the former's expansion in coil-heated sweeps --------------------------------------------
def with_former_expansion(data: Measurements, per_k: float) -> Measurements:
    """The readings a winding scaled by 1 + a dT would give: k(x) of the expanded coil (image method)."""
    from ecds_lab.data.sensor import SensorConfig
    from ecds_lab.model.coupling import image_method_coupling

    sensor = SensorConfig()
    truth = fit(data.select(data.t_coil_c < 30), [])
    tau, coil = truth.values["tau_t"], sensor.coil
    out = data.ls_h.copy()
    for level in np.unique(np.round(data.t_coil_c)):
        rows = (np.round(data.t_coil_c) == level) & np.isfinite(data.x_m)
        scale = 1 + per_k * (level - sensor.reference_temperature_c)
        expanded = image_method_coupling(coil.model_copy(update={
            "inner_radius_m": coil.inner_radius_m * scale, "outer_radius_m": coil.outer_radius_m * scale,
            "height_m": coil.height_m * scale}))
        cold = image_method_coupling(coil)
        omega_tau2 = (2 * np.pi * data.freq_hz[rows] * tau) ** 2
        f_t = omega_tau2 / (1 + omega_tau2)
        x = data.x_m[rows]
        out[rows] *= (1 - expanded(x) ** 2 * f_t) / (1 - cold(x) ** 2 * f_t)
    return dataclasses.replace(data, ls_h=out)


def test_coil_heated_sweeps_reveal_the_former_expansion():
    lab = lab_with()
    room = campaign.displacement_sweep(lab, POSITIONS_MM)
    hot = campaign.coil_heated_sweeps(lab, (70, 120), positions_mm=POSITIONS_MM)
    air = campaign.coil_heating(lab, (60, 100), interval_s=300.0)
    data = with_former_expansion(Measurements.concatenate([room, hot, air]), 25e-6)  # gypsum
    result = run_diagnosis(data)
    assert result.claimed[:1] == ["former_expansion"], [(c.effect, c.rejected) for c in result.candidates]
    assert result.final.fit.values["former_alpha"] == pytest.approx(25e-6, rel=0.3)
    assert result.final.rmse_ppm <= 1.5 * result.noise_ppm


# -- honest verdicts -----------------------------------------------------------------------------------
def test_a_short_uninformative_campaign_claims_nothing():
    lab = lab_with(target_bending={})
    data = campaign.displacement_sweep(lab, (30, 45, 60, 80, 100), (15000.0,), directions=("forward",))
    result = run_diagnosis(data)
    assert result.verdict in ("inconclusive", "adequate")
    assert result.claimed == []


# -- the user's own effect (docs/user_effects.md) ---------------------------------------------------------
def metal_object_campaign(tmp_path: Path) -> Path:
    """The paper campaign with a metal object beside the slide near 47 mm: L dips by 400 ppm there."""
    data = campaign.paper_campaign(LabConfig(), seed=4)
    x = np.where(np.isfinite(data.x_m), data.x_m, np.inf)
    dip = 1 - 400e-6 * np.exp(-0.5 * ((x - 0.047) / 0.005) ** 2)
    path = tmp_path / "campaign.csv"
    dataclasses.replace(data, ls_h=data.ls_h * dip).to_csv(path)
    return path


def test_the_user_effect_walkthrough(tmp_path, capsys):
    path = metal_object_campaign(tmp_path)
    assert main(["diagnose", str(path), "--json"]) == 0
    before = json.loads(capsys.readouterr().out)
    assert before["verdict"] == "missing_effect"
    assert before["associations"][0]["variable"] == "x_mm"
    assert "outside the library" in before["explanation"]
    effect_file = tmp_path / "my_effects.py"
    shutil.copy(EXAMPLE, effect_file)
    assert len(effect_file.read_text().splitlines()) <= 25
    assert main(["fit", str(path), "--effects-from", str(effect_file), "--effects", "metal_object", "--json"]) == 0
    fitted = json.loads(capsys.readouterr().out)
    assert fitted["params"]["object_x"]["value"] == pytest.approx(0.047, abs=1e-3)
    assert main(["diagnose", str(path), "--effects-from", str(effect_file), "--json"]) == 0
    after = json.loads(capsys.readouterr().out)
    assert after["claimed"][:1] == ["metal_object"], after["explanation"]
    assert after["steps"][-1]["rmse_ppm"] <= 1.5 * after["noise_ppm"] < before["baseline"]["rmse_ppm"]
    assert after["steps"][-1]["position_error_mm"] < before["steps"][0]["position_error_mm"]
    assert "metal_object" not in library()  # the file's effect joined only that command's registry


def test_several_data_files_are_one_campaign(campaign_with, tmp_path, capsys):
    data = campaign_with("slide_backlash")
    half = len(data) // 2
    paths = [tmp_path / "a.csv", tmp_path / "b.csv"]
    data.select(np.arange(half)).to_csv(paths[0])
    data.select(np.arange(half, len(data))).to_csv(paths[1])
    assert main(["fit", *map(str, paths), "--effects", "slide_backlash", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["params"]["backlash"]["value"] == pytest.approx(40e-6, rel=0.2)


def test_a_broken_effect_file_is_a_clear_error(tmp_path, capsys):
    bad = tmp_path / "bad.py"
    bad.write_text("x = 1\n")
    data = tmp_path / "d.csv"
    campaign.displacement_sweep(lab_with(), (30, 60, 90), (15000.0,)).to_csv(data)
    assert main(["diagnose", str(data), "--effects-from", str(bad)]) == 2
    assert "defines no Effect subclass" in capsys.readouterr().err


def test_an_installed_package_s_effects_come_through_the_entry_point_group(monkeypatch):
    """An entry point in group ``ecds_lab.effects`` naming an Effect class joins the registry."""
    from importlib.metadata import EntryPoint

    from ecds_lab.model import plugins

    point = EntryPoint("bracket", "ecds_lab_test_bracket:MetalObject", plugins.ENTRY_POINT_GROUP)
    spec = importlib.util.spec_from_file_location("ecds_lab_test_bracket", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # the package a user would have installed
    monkeypatch.setitem(sys.modules, "ecds_lab_test_bracket", module)
    monkeypatch.setattr(plugins, "entry_points", lambda group: [point] if group == plugins.ENTRY_POINT_GROUP else [])
    plugins.entry_point_effects.cache_clear()
    try:
        assert plugins.load_entry_points() == ["metal_object"]
        assert "metal_object" in library()
    finally:
        plugins.entry_point_effects.cache_clear()  # the next library() reads the real entry points again
