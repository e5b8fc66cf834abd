"""Units that look wrong for the data contract (°C, H) are named before the analysis reads them as physics."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from ecds_lab.analysis.suspect_units import unit_notes
from ecds_lab.cli import main
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.storage.data_file import open_data

SWEEP = Path(__file__).resolve().parent.parent / "data" / "sessions" / "sweep.h5"


@pytest.fixture(scope="module")
def sweep():
    return open_data(SWEEP)


def test_a_recorded_sweep_raises_no_note(sweep):
    assert unit_notes(sweep.data, sweep.sensor) == []


def test_temperatures_in_kelvin_are_named(sweep):
    kelvin = dataclasses.replace(sweep.data, t_coil_c=sweep.data.t_coil_c + 273.15)
    (note,) = unit_notes(kelvin, sweep.sensor)
    assert note.startswith("t_coil_c has a median of 29") and "kelvin" in note


def test_an_inductance_in_millihenry_is_named_with_the_sensor_it_was_compared_with(sweep):
    millihenry = dataclasses.replace(sweep.data, ls_h=sweep.data.ls_h * 1e3)
    (note,) = unit_notes(millihenry, sweep.sensor)
    assert note.startswith("ls_h has a median of") and f"({sweep.sensor.name}: 57 mH)" in note
    assert "--sensor" in note
    # the same readings against a coil described as 1000x larger raise none
    assert unit_notes(millihenry, SensorConfig(inductance_h=57.0)) == []


def test_fit_and_diagnose_put_the_notes_first(sweep, tmp_path, capsys):
    csv = tmp_path / "mh.csv"
    dataclasses.replace(sweep.data, ls_h=sweep.data.ls_h * 1e3).to_csv(csv)
    assert main(["fit", str(csv)]) == 0
    head = capsys.readouterr().out.splitlines()[:3]
    assert any(line.startswith("note: ls_h has a median of") for line in head), head


def test_the_report_says_which_units_to_check(sweep, tmp_path, capsys):
    csv = tmp_path / "kelvin.csv"
    dataclasses.replace(sweep.data, t_target_c=sweep.data.t_target_c + 273.15).to_csv(csv)
    output = tmp_path / "report.html"
    assert main(["report", str(csv), "-o", str(output)]) == 0
    capsys.readouterr()
    assert "Units to check before reading the figures below: kelvin.csv: t_target_c has a median of" in \
        output.read_text()
