"""The sensor travels with the run: a station names it, the run file records it, and ``fit``,
``diagnose`` and ``report`` analyse the file as that sensor without ``--sensor``.

For the simulated lab and for a real-station YAML whose instruments are a recorded session
served through the drivers (replay transports); a station naming no sensor is said to be so.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from html import escape
from pathlib import Path

import h5py
import pytest

from ecds_lab.cli import main
from ecds_lab.data.sensor import DEFAULT_SENSOR_NOTE
from ecds_lab.runner import session
from ecds_lab.storage.data_file import open_data

ROOT = Path(__file__).resolve().parents[2]
SESSIONS = ROOT / "tests" / "data" / "sessions"
REAL_TEMPLATE = ROOT / "experiments" / "stations" / "real_lab_template.yaml"


def as_json(capsys: pytest.CaptureFixture[str], *args: str) -> dict:
    assert main([*args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def report_of(capsys: pytest.CaptureFixture[str], run: Path, tmp_path: Path) -> str:
    """The HTML ``ecds-lab report`` writes for one run file."""
    output = tmp_path / f"{run.stem}-report.html"
    assert main(["report", str(run), "-o", str(output)]) == 0
    capsys.readouterr()
    return output.read_text()


@pytest.fixture
def real_station_run(tmp_path: Path, session_copy: Callable[..., Path], as_real_lab_recording,
                     monkeypatch: pytest.MonkeyPatch) -> Callable[[str], Path]:
    """``real_station_run(sensor_line)``: ``ecds-lab run`` of the recorded sweep on the real lab's station
    YAML with ``sensor_line`` in place of the template's, its instruments the recorded session (replayed)."""
    from ecds_lab.replay import replay_station

    recording = session_copy("sweep", as_real_lab_recording)
    monkeypatch.setattr(session, "open_station", lambda config, text="": replay_station(recording))

    def run(sensor_line: str) -> Path:
        station = tmp_path / "real_station.yaml"
        station.write_text(REAL_TEMPLATE.read_text().replace("sensor: paper_prototype\n", sensor_line))
        output = tmp_path / "real_run.h5"
        result = session.run_experiment(SESSIONS / "sweep.yaml", station, output, progress=False, overwrite=True)
        assert (result.status, result.points) == ("completed", 20), result.error
        return output

    return run


def test_a_simulated_steel_station_records_its_sensor(shipped_run):
    run = shipped_run("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml").path
    with h5py.File(run) as f:
        assert json.loads(f["entry"].attrs["sensor"])["target"] == "steel"
    opened = open_data(run)
    assert (opened.sensor.target, opened.sensor_source, opened.sensor_note) == ("steel", "run file", None)


def test_fit_diagnose_and_report_analyse_a_simulated_steel_run_as_steel(shipped_run, capsys, tmp_path):
    run = shipped_run("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml").path
    fitted = as_json(capsys, "fit", str(run))
    assert fitted["sensor"] == {"name": "Gruber 2024 prototype, steel target", "target": "steel",
                                "former": "fired_clay", "source": "run file"}
    assert "notes" not in fitted
    # a steel-like effective tau_T (a few us on the faithful lab), not copper's >= 100 us
    assert fitted["params"]["tau_t"]["value"] < 10e-6
    diagnosed = as_json(capsys, "diagnose", str(run))
    assert diagnosed["sensor"]["target"] == "steel" and "notes" not in diagnosed
    assert diagnosed["baseline"]["params"]["tau_t"]["value"] < 10e-6
    html = report_of(capsys, run, tmp_path)
    assert "target: steel" in html and "sensor: Gruber 2024 prototype, steel target" in html
    assert "steel target: baseline fit" in html and escape(DEFAULT_SENSOR_NOTE) not in html


def test_sensor_overrides_what_the_run_file_records(shipped_run, capsys):
    run = shipped_run("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml").path
    fitted = as_json(capsys, "fit", str(run), "--sensor", "paper_prototype")
    assert fitted["sensor"] == {"name": "Gruber 2024 prototype", "target": "copper", "former": "fired_clay",
                                "source": "--sensor paper_prototype"}
    assert fitted["params"] != as_json(capsys, "fit", str(run))["params"]  # the model of another target


def test_a_real_station_naming_a_steel_sensor_is_analysed_as_steel(real_station_run, capsys, tmp_path):
    run = real_station_run("sensor: steel_target\n")
    opened = open_data(run)
    assert opened.run is not None and opened.run.station == "ECDS lab (real)"
    assert (opened.sensor.target, opened.sensor_source) == ("steel", "run file")
    fitted = as_json(capsys, "fit", str(run))
    assert fitted["sensor"]["target"] == "steel" and "notes" not in fitted
    diagnosed = as_json(capsys, "diagnose", str(run))
    assert diagnosed["sensor"]["target"] == "steel" and "notes" not in diagnosed
    html = report_of(capsys, run, tmp_path)
    assert "target: steel" in html and escape(DEFAULT_SENSOR_NOTE) not in html


def test_a_real_station_naming_an_inline_sensor_records_it(real_station_run):
    run = real_station_run("sensor: {name: my coil on steel, target: steel, former: gypsum}\n")
    sensor = open_data(run).sensor
    assert (sensor.name, sensor.target, sensor.former) == ("my coil on steel", "steel", "gypsum")


def test_a_station_naming_no_sensor_is_analysed_as_copper_and_says_so(real_station_run, capsys, tmp_path):
    run = real_station_run("")
    with h5py.File(run) as f:
        assert "sensor" not in f["entry"].attrs
    fitted = as_json(capsys, "fit", str(run))
    assert fitted["sensor"]["target"] == "copper" and fitted["sensor"]["source"] == "not recorded"
    assert fitted["notes"] == [DEFAULT_SENSOR_NOTE]
    assert as_json(capsys, "diagnose", str(run))["notes"] == [DEFAULT_SENSOR_NOTE]
    assert main(["fit", str(run)]) == 0
    assert f"note: {DEFAULT_SENSOR_NOTE}" in capsys.readouterr().out.splitlines()[:2]
    assert escape(DEFAULT_SENSOR_NOTE) in report_of(capsys, run, tmp_path)


def test_fit_and_diagnose_report_the_same_noise(shipped_run, capsys):
    run = str(shipped_run("displacement_sweep.yaml").path)
    fitted, diagnosed = as_json(capsys, "fit", run), as_json(capsys, "diagnose", run)
    assert fitted["noise_ppm"] == diagnosed["noise_ppm"] > 0
    assert fitted["noise_method"] == diagnosed["noise_method"] == "repeated readings"
