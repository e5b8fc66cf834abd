"""The command line's own logic: which sensor describes DATA, and clear errors for bad sensor files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ecds_lab.cli import main

SENSORS = Path(__file__).resolve().parent.parent / "experiments" / "sensors"


def fitted(capsys: pytest.CaptureFixture[str], *args: str) -> dict:
    assert main(["fit", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_a_run_file_brings_its_own_sensor(shipped_run, capsys):
    steel_run = shipped_run("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml").path
    from_run = fitted(capsys, str(steel_run))
    from_yaml = fitted(capsys, str(steel_run), "--sensor", str(SENSORS / "steel_target.yaml"))
    assert from_run["params"]["tau_t"]["value"] == pytest.approx(from_yaml["params"]["tau_t"]["value"])
    assert from_run["params"]["tau_t"]["value"] < 10e-6  # steel (a few us on the faithful lab), not copper


def test_every_shipped_sensor_file_is_valid(capsys, shipped_run):
    run = shipped_run("displacement_sweep.yaml").path
    for sensor in SENSORS.glob("*.yaml"):
        assert fitted(capsys, str(run), "--sensor", str(sensor))["rmse_ppm"] > 0


def test_a_bad_sensor_file_names_the_field(tmp_path, shipped_run, capsys):
    bad = tmp_path / "sensor.yaml"
    bad.write_text("target: gold\n")
    run = shipped_run("displacement_sweep.yaml").path
    assert main(["fit", str(run), "--sensor", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "sensor.yaml" in err and "target" in err and "copper" in err


def test_one_campaign_diagnosed_on_two_processes_says_what_it_says_on_one(shipped_run, capsys):
    run = shipped_run("displacement_sweep.yaml").path
    said = []
    for workers in ("1", "2"):
        assert main(["diagnose", str(run), "--workers", workers, "--json"]) == 0
        said.append(json.loads(capsys.readouterr().out))
    assert said[0] == said[1]


def test_workers_below_one_are_refused(shipped_run, capsys):
    run = shipped_run("displacement_sweep.yaml").path
    assert main(["diagnose", str(run), "--workers", "0"]) == 2
    assert "--workers must be at least 1, got 0" in capsys.readouterr().err
