"""The fit summary behind `ecds-lab fit --json`: contract keys, calibration, position errors, text form."""

from __future__ import annotations

import json

import pytest

from ecds_lab.analysis.summary import fit_summary, format_fit_summary
from ecds_lab.model.effects import Effect, library
from ecds_lab.simulators.campaign import displacement_sweep, paper_campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab


@pytest.fixture(scope="module")
def summary():
    return fit_summary(paper_campaign(LabConfig(), seed=13), [])


def test_summary_is_json_with_the_contract_keys(summary):
    text = json.dumps(summary, allow_nan=False)
    back = json.loads(text)
    assert {"rmse_ppm", "effects", "params"} <= set(back)
    assert back["effects"] == []
    assert back["params"]["L0"]["unit"] == "H" and back["params"]["L0"]["stderr"] > 0
    assert set(back["params"]["alpha"]) >= {"value", "stderr", "unit"}
    assert abs(back["rmse_ppm"] / (LabConfig().noise.bridge_relative["slow"] * 1e6) - 1) < 0.2


def test_summary_calibrates_each_frequency_and_reports_position_errors(summary):
    by_freq = {c["freq_hz"]: c for c in summary["calibration"]}
    assert set(by_freq) == {500.0, 15000.0}
    high = by_freq[15000.0]
    assert high["all_points"]["n_points"] == 31 and high["n4"]["n_points"] == 4
    assert high["all_points"]["fs_mm"] == pytest.approx(80.0)
    coil = high["all_points"]["coil_heated"]
    assert coil["compensated_ratio"] <= 0.15
    assert coil["compensated"]["delta_t_k"] > 90
    target = high["all_points"]["target_heated"]
    assert target["delta_t_k"] > 100
    # the baseline simulation has no target effect, so heating the target leaves noise-level errors
    assert target["max_abs_fs_percent"] < 0.2
    assert high["n4"]["room_temperature"]["max_abs_mm"] < 2 * high["all_points"]["room_temperature"]["max_abs_mm"]


def test_text_form_names_parameters_and_errors(summary):
    text = format_fit_summary(summary)
    assert "residual RMS" in text and "alpha" in text and "15000 Hz" in text and "compensated" in text


def test_summary_without_a_sweep_has_no_calibration():
    data = displacement_sweep(SimulatedLab(LabConfig(seed=2)), positions_mm=(30.0, 60.0), air_repeats=3)
    result = fit_summary(data)
    assert result["calibration"] == []
    assert "p2" in result["fixed"]


def test_unknown_effect_names_fail_listing_the_known_ones():
    class Demo(Effect):
        name = "demo_effect"

    registry = library().with_effects(Demo)
    data = displacement_sweep(SimulatedLab(LabConfig(seed=2)), positions_mm=(30.0, 60.0))
    with pytest.raises(ValueError, match="demo_effect"):
        fit_summary(data, ["no_such_effect"], registry=registry)
    assert fit_summary(data, ["demo_effect"], registry=registry)["effects"] == ["demo_effect"]


@pytest.fixture(scope="module")
def steel_summary(shipped_run):
    from ecds_lab.storage.data_file import open_data

    opened = open_data(shipped_run("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml").path)
    return fit_summary(opened.data, [], opened.sensor)


def test_text_flags_the_out_of_range_readings_the_json_flags(steel_summary):
    text = format_fit_summary(steel_summary)
    flagged = [(cal["freq_hz"], label, entry) for cal in steel_summary["calibration"]
               for label in ("all_points", "n4") for entry in [cal[label]["room_temperature"]] if entry["out_of_range"]]
    assert flagged, "the steel run at 500 Hz has readings outside the calibrated range"
    for _, _, entry in flagged:
        # no figure counts a clamped reading as a length
        assert entry["max_abs_mm"] is None or entry["max_abs_mm"] < entry["fs_mm"]
    assert "out of range" in text
    for line in text.splitlines():
        if "max |e|" in line and "out of range" not in line:
            value = float(line.split("max |e| ")[1].split()[0])
            assert value < 80.0 or "µm" in line


def test_parameters_carry_their_status_in_json_and_text(steel_summary):
    params = steel_summary["params"]
    assert {p["status"] for p in params.values()} >= {"fixed", "undetermined"}
    assert params["R_p"]["status"] == "fixed" and params["R_p"]["status_reason"]
    text = format_fit_summary(steel_summary)
    for name, p in params.items():
        line = next(li for li in text.splitlines() if li.strip().startswith(name + " "))
        assert p["status"] in line and "0.0000" not in line


def test_a_model_far_above_the_noise_is_flagged_in_json_and_text(steel_summary, summary):
    assert steel_summary["model"]["status"] == "model fails here" and "x the" in steel_summary["model"]["reason"]
    assert "model fails here" in format_fit_summary(steel_summary).splitlines()[2]
    assert summary["model"] == {"status": "valid"}
