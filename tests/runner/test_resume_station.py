"""--resume continues on the station of the interrupted run, or refuses naming the difference."""

from __future__ import annotations

import pytest

from ecds_lab.cli import main
from ecds_lab.errors import ConfigError
from ecds_lab.runner.session import run_experiment
from ecds_lab.storage.reader import read_run

SWEEP = "displacement_sweep.yaml"


@pytest.fixture
def interrupted(tmp_path, experiments_dir, yaml_copy, opened_stations, at_simulated_time):
    experiment = yaml_copy(SWEEP, lambda d: d["sweep"].update(positions_mm=[20.0, 30.0, 40.0, 50.0]))
    at_simulated_time(40.0, KeyboardInterrupt)
    path = tmp_path / "part.h5"
    assert run_experiment(experiment, None, path, progress=False).status == "aborted"
    return experiment, path


def test_resume_on_the_steel_station_names_the_sensor(interrupted, experiments_dir, tmp_path, instrument_guard):
    experiment, path = interrupted
    refused = (r"cannot resume on another station \(sensor: recorded '[^']+', "
               r"station .*steel.yaml has '[^']*steel target'")
    with pytest.raises(ConfigError, match=refused):
        run_experiment(experiment, experiments_dir / "stations" / "simulated_lab_steel.yaml", tmp_path / "r.h5",
                       resume=path, progress=False)
    assert instrument_guard.untouched  # refused before any instrument was opened


def test_resume_of_a_simulated_run_on_a_real_station_is_refused(interrupted, experiments_dir, tmp_path, capsys,
                                                                instrument_guard):
    experiment, path = interrupted
    code = main(["run", str(experiment), "--resume", str(path), "-o", str(tmp_path / "r.h5"),
                 "--station", str(experiments_dir / "stations" / "real_lab_template.yaml")])
    assert code == 2
    err = capsys.readouterr().err
    assert "the interrupted run was on a simulated station" in err and "is real" in err
    assert instrument_guard.untouched


def test_resume_with_other_instruments_names_them(interrupted, tmp_path, monkeypatch):
    experiment, path = interrupted
    monkeypatch.setattr("ecds_lab.simulators.hm8118.IDENTITY", "HAMEG,HM8118,999999,1.99")
    with pytest.raises(ConfigError, match=r"bridge: recorded '.*', now 'HAMEG,HM8118,999999,1.99'"):
        run_experiment(experiment, None, tmp_path / "r.h5", resume=path, progress=False)
    assert not (tmp_path / "r.h5").exists()


def test_resume_on_the_same_station_still_completes(interrupted, tmp_path):
    experiment, path = interrupted
    result = run_experiment(experiment, None, tmp_path / "r.h5", resume=path, progress=False)
    assert result.status == "completed" and read_run(tmp_path / "r.h5").status == "completed"
