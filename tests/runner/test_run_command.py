"""`ecds-lab run`: existing files, --dry-run, and the shipped experiments running to completion."""

from __future__ import annotations

import pytest

from ecds_lab.cli import main
from ecds_lab.data.columns import PLANNED_POINT
from ecds_lab.runner.plan import build_plan
from ecds_lab.runner.session import load_experiment
from ecds_lab.storage.reader import read_run


@pytest.fixture
def short_sweep(yaml_copy):
    return yaml_copy("displacement_sweep.yaml", lambda d: d["sweep"].update(positions_mm=[20.0, 30.0]))


def test_an_existing_run_file_is_not_overwritten(short_sweep, tmp_path, instrument_guard, capsys):
    output = tmp_path / "run.h5"
    output.write_bytes(b"an earlier run")
    assert main(["run", str(short_sweep), "-o", str(output), "-q"]) == 2
    err = capsys.readouterr().err
    assert str(output) in err and "--overwrite" in err
    assert output.read_bytes() == b"an earlier run"
    assert instrument_guard.untouched


def test_overwrite_replaces_the_run_file(short_sweep, tmp_path, capsys):
    output = tmp_path / "run.h5"
    output.write_bytes(b"an earlier run")
    assert main(["run", str(short_sweep), "-o", str(output), "-q", "--overwrite"]) == 0
    run = read_run(output)
    assert run.status == "completed"
    assert len(run.points) == len(build_plan(load_experiment(short_sweep)).points)
    assert capsys.readouterr().out.startswith(f"completed: {len(run.points)} rows in {output}")


def test_dry_run_prints_the_plan_and_touches_no_instrument(experiments_dir, tmp_path, instrument_guard, capsys):
    experiment = experiments_dir / "displacement_sweep.yaml"
    output = tmp_path / "run.h5"
    assert main(["run", str(experiment), "--dry-run", "-o", str(output)]) == 0
    lines = capsys.readouterr().out.splitlines()
    plan = build_plan(load_experiment(experiment))
    steps = lines[1:len(plan.steps) + 1]
    assert f"{len(plan.points)} planned readings" in lines[0] and lines[len(plan.steps) + 1] == "summary:"
    assert [line.split(None, 1) for line in steps] == [[str(i), s.describe()] for i, s in enumerate(plan.steps)]
    assert sum(line.split(None, 1)[1].startswith("planned reading ") for line in steps) == len(plan.points)
    assert instrument_guard.untouched and not output.exists()


@pytest.mark.parametrize("experiment, station", [
    ("displacement_sweep.yaml", None),
    ("coil_heating.yaml", None),
    ("target_heating_copper.yaml", None),
    ("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml"),
])
def test_shipped_experiments_complete(experiment, station, experiments_dir, shipped_run):
    result = shipped_run(experiment, station)
    plan = build_plan(load_experiment(experiments_dir / experiment))
    run = read_run(result.path)
    assert result.status == "completed" and run.status == "completed", result.error
    planned = run.column("kind") == PLANNED_POINT
    assert sorted(run.column("point")[planned].astype(int)) == list(range(len(plan.points)))
    assert result.points == len(run.points) == int(run.metadata["points"])
    assert int(run.metadata["planned_points"]) == len(plan.points)
