"""Shipped experiments, stations and sensors are named anywhere: `run displacement_sweep --station simulated_lab`
from any folder, `ecds-lab list` shows them, and a name that is neither a file nor shipped is one clear line."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ecds_lab import shipped
from ecds_lab.cli import build_parser, main
from ecds_lab.config.references import experiment_path, station_path
from ecds_lab.errors import ConfigError
from ecds_lab.storage.reader import read_run

CHECKOUT = Path(__file__).resolve().parents[2]


def ecds_lab(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """The command as a user types it, in a folder that is not the checkout (no PYTHONPATH to it)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([sys.executable, "-m", "ecds_lab.cli", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def test_a_shipped_experiment_and_station_run_by_name_outside_the_checkout(tmp_path):
    assert CHECKOUT not in tmp_path.parents
    done = ecds_lab("run", "displacement_sweep", "--station", "simulated_lab", "-q", "-o", "sweep.h5", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    run = read_run(tmp_path / "sweep.h5", transcripts=False)
    assert run.metadata["status"] == "completed"
    assert run.metadata["experiment_yaml"] == shipped.experiment("displacement_sweep.yaml").read_text()
    assert run.metadata["station_yaml"] == shipped.station("simulated_lab.yaml").read_text()


def test_the_dry_run_takes_names_with_or_without_the_suffix(capsys):
    assert main(["run", "displacement_sweep.yaml", "--station", "simulated_lab_steel", "--dry-run"]) == 0
    assert "displacement sweep 20-100 mm" in capsys.readouterr().out


def test_a_file_in_the_current_folder_wins_over_a_shipped_name(tmp_path, monkeypatch):
    own = tmp_path / "displacement_sweep.yaml"
    own.write_text("kind: displacement_sweep\nname: my own\nsweep: {positions_mm: [30.0], frequencies_hz: [500]}\n")
    monkeypatch.chdir(tmp_path)
    assert experiment_path("displacement_sweep.yaml").resolve() == own.resolve()
    assert experiment_path("displacement_sweep") == shipped.experiment("displacement_sweep.yaml")


def test_an_unknown_name_is_one_line_listing_the_shipped_names(capsys):
    assert main(["run", "displacment_sweep", "--dry-run"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert "displacment_sweep" in err and "displacement_sweep" in err and "target_heating_steel" in err
    assert main(["run", "displacement_sweep", "--dry-run", "--station", "no_lab"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "no_lab" in err and "simulated_lab_steel" in err


def test_a_path_that_does_not_exist_is_not_taken_for_a_name(tmp_path):
    with pytest.raises(ConfigError, match=r"cannot read: No such file.*displacement_sweep"):
        experiment_path(tmp_path / "displacement_sweep.yaml")
    with pytest.raises(ConfigError, match="simulated_lab"):
        station_path("stations/simulated_lab.yaml")


def test_help_shows_the_default_station_by_name_not_a_checkout_path():
    parser = build_parser()
    run = next(a for a in parser._subparsers._group_actions[0].choices["run"]._actions  # type: ignore[union-attr]
               if a.dest == "station")
    assert "simulated_lab" in run.help
    assert "/" not in run.help and "experiments" not in run.help


def test_list_shows_every_shipped_experiment_with_its_kind_and_every_station_and_sensor(tmp_path):
    done = ecds_lab("list", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    for path in shipped.experiments():
        line = next(line for line in lines if line.split()[:1] == [path.stem])
        assert path.read_text().split("kind:")[1].split()[0] in line
    for path in shipped.stations_folder().glob("*.yaml"):
        assert any(line.split()[:1] == [path.stem] for line in lines)
    for path in shipped.sensors_folder().glob("*.yaml"):
        assert any(line.split()[:1] == [path.stem] for line in lines)
    assert "displacement sweep 20-100 mm" in done.stdout


def test_a_sensor_is_named_like_experiments_and_stations(tmp_path, monkeypatch):
    from ecds_lab.data.sensor import load_sensor, sensor_path

    monkeypatch.chdir(tmp_path)
    assert sensor_path("steel_target.yaml") == sensor_path("steel_target") == shipped.sensors_folder() / \
        "steel_target.yaml"
    assert load_sensor("steel_target.yaml").target == "steel"
    with pytest.raises(ConfigError, match=r"brass\.yaml.*paper_prototype, steel_target"):
        sensor_path("brass.yaml")
    own = tmp_path / "steel_target.yaml"
    own.write_text("name: my own\ntarget: copper\n")
    assert load_sensor("steel_target.yaml").name == "my own"  # a file here wins over the shipped name
