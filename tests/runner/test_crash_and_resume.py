"""A run killed with SIGKILL leaves a readable file; --resume completes it into a new file."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from ecds_lab.cli import main
from ecds_lab.data.columns import INDEX, PLANNED_POINT
from ecds_lab.errors import RunFileError
from ecds_lab.runner.plan import build_plan
from ecds_lab.runner.session import load_experiment
from ecds_lab.storage.reader import read_run

SWEEP = "displacement_sweep.yaml"
#: Columns every planned point of a displacement sweep measures (heater powers are not read without heating).
MEASURED = ("time_s", "wall_time_s", "x_commanded_mm", "x_readback_mm", "direction", "freq_hz",
            "t_coil_c", "t_target_c", "t_ambient_c", "ls_h", "rs_ohm")
KILL_AFTER_ROWS = 20


def cli(*args: object) -> list[str]:
    return [sys.executable, "-m", "ecds_lab.cli", *map(str, args)]


def planned(run) -> np.ndarray:
    """The planned-point rows of a RunFile."""
    return run.points[run.column("kind") == PLANNED_POINT]


def rows_in(path) -> int:
    try:
        return len(read_run(path, transcripts=False).points)
    except RunFileError:  # not created yet, or not yet in SWMR mode
        return 0


def kill_after_rows(command: list[str], path, rows: int, timeout_s: float = 30.0) -> None:
    """Start ``command``; SIGKILL it once ``path`` holds at least ``rows`` rows."""
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + timeout_s
        while rows_in(path) < rows:
            if process.poll() is not None:
                pytest.fail(f"the run ended before it was killed: {process.communicate()}")
            if time.monotonic() > deadline:
                pytest.fail(f"{path} did not reach {rows} rows within {timeout_s} s")
            time.sleep(0.02)
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == -signal.SIGKILL


def test_sigkill_leaves_every_point_and_resume_completes_the_plan(tmp_path, experiments_dir, yaml_copy,
                                                                   shipped_run):
    # a station whose simulated time runs slowly enough that the sweep takes several seconds
    slow_station = yaml_copy("stations/simulated_lab.yaml", lambda d: d["simulated"].update(real_time_factor=0.02))
    experiment = experiments_dir / SWEEP
    killed_path, resumed_path = tmp_path / "run.h5", tmp_path / "resumed.h5"
    kill_after_rows(cli("run", experiment, "--station", slow_station, "-o", killed_path, "-q"), killed_path,
                    KILL_AFTER_ROWS)

    killed = read_run(killed_path)
    assert killed.status == "interrupted"
    rows = planned(killed)
    assert len(rows) == len(killed.points) >= KILL_AFTER_ROWS
    assert np.isfinite(rows[:, [INDEX[c] for c in MEASURED]]).all()
    numbers = rows[:, INDEX["point"]].astype(int)
    assert list(numbers) == list(range(len(numbers)))
    plan_points = len(build_plan(load_experiment(experiment)).points)
    assert len(numbers) < plan_points

    before = (hashlib.sha256(killed_path.read_bytes()).hexdigest(), killed_path.stat().st_mtime_ns)
    done = subprocess.run(cli("run", experiment, "--resume", killed_path, "-o", resumed_path, "-q"),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert (hashlib.sha256(killed_path.read_bytes()).hexdigest(), killed_path.stat().st_mtime_ns) == before

    resumed = read_run(resumed_path)
    assert resumed.status == "completed"
    assert resumed.metadata["resumed_from"] == str(killed_path)
    points = planned(resumed)[:, INDEX["point"]].astype(int)
    assert sorted(points) == list(range(plan_points))  # every planned point exactly once
    np.testing.assert_array_equal(resumed.points[:len(killed.points)], killed.points)  # carried over as recorded
    assert np.all(np.diff(resumed.column("time_s")) >= 0)  # time continues across the resume
    for role, events in killed.transcripts.items():  # the old traffic is kept ahead of the new
        assert resumed.transcripts[role][:len(events)] == events

    # the same points as an uninterrupted run of the plan: same count, each at the same place and frequency
    full = read_run(shipped_run(SWEEP).path)
    assert full.status == "completed" and len(planned(full)) == plan_points
    by_point = lambda rows: rows[np.argsort(rows[:, INDEX["point"]])]  # noqa: E731
    for column in ("point", "x_commanded_mm", "freq_hz", "direction", "reading"):
        np.testing.assert_array_equal(by_point(planned(resumed))[:, INDEX[column]],
                                      by_point(planned(full))[:, INDEX[column]])


@pytest.fixture
def interrupted_run(tmp_path, experiments_dir, yaml_copy, opened_stations, at_simulated_time):
    """A small sweep stopped by Ctrl-C part way (in-process): (experiment, run file)."""
    experiment = yaml_copy(SWEEP, lambda d: d["sweep"].update(positions_mm=[20.0, 30.0, 40.0, 50.0]))
    at_simulated_time(40.0, KeyboardInterrupt)
    path = tmp_path / "part.h5"
    assert main(["run", str(experiment), "-o", str(path), "-q"]) == 130  # Ctrl-C: 128 + SIGINT, as shells expect
    run = read_run(path)
    assert run.status == "aborted" and 0 < len(planned(run)) < len(build_plan(load_experiment(experiment)).points)
    return experiment, path


def test_resume_refuses_another_experiment(interrupted_run, yaml_copy, instrument_guard, tmp_path, capsys):
    _, path = interrupted_run
    other = yaml_copy(SWEEP, lambda d: d["sweep"].update(positions_mm=[20.0, 30.0]), name="other.yaml")
    assert main(["run", str(other), "--resume", str(path), "-o", str(tmp_path / "new.h5")]) == 2
    err = capsys.readouterr().err
    assert str(other) in err and str(path) in err and "same experiment" in err
    assert instrument_guard.untouched and not (tmp_path / "new.h5").exists()


def test_resume_never_writes_over_the_interrupted_file(interrupted_run, instrument_guard, capsys):
    experiment, path = interrupted_run
    before = path.read_bytes()
    assert main(["run", str(experiment), "--resume", str(path), "-o", str(path), "--overwrite"]) == 2
    assert "never modifies" in capsys.readouterr().err
    assert path.read_bytes() == before and instrument_guard.untouched


def test_resume_of_an_aborted_run_completes_it(interrupted_run, tmp_path):
    experiment, path = interrupted_run
    assert main(["run", str(experiment), "--resume", str(path), "-q"]) == 0
    resumed = read_run(path.with_name(path.stem + "-resumed.h5"))  # the default name next to the old file
    assert resumed.status == "completed"
    points = planned(resumed)[:, INDEX["point"]].astype(int)
    assert sorted(points) == list(range(len(build_plan(load_experiment(experiment)).points)))
