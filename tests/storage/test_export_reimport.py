"""An exported CSV keeps every reading and re-imports to the same analysis as its run file (issue 24, point 7):
readings taken before the slide had a position are rows with x_mm = nan, and the sidecar carries each
reading's direction and the station's declared figures (sensor, slide repeatability)."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import diagnose
from ecds_lab.analysis.summary import fit_summary
from ecds_lab.cli import main
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sidecar import SidecarError
from ecds_lab.storage.data_file import open_data
from ecds_lab.storage.reader import read_run

STEEL = ("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml")


@pytest.fixture(scope="module")
def exported(shipped_run, tmp_path_factory):
    """The steel run (it has readings before the slide's first move) and its export."""
    run = shipped_run(*STEEL).path
    output = tmp_path_factory.mktemp("export") / "steel.csv"
    assert main(["export", str(run), "-o", str(output)]) == 0
    return run, output


def test_every_reading_is_a_row_and_an_unknown_position_is_nan(exported, capsys):
    run, output = exported
    points = read_run(run, transcripts=False)
    readings = int(np.isfinite(points.column("ls_h")).sum())
    unpositioned = int((np.isfinite(points.column("ls_h")) & np.isnan(points.column("x_commanded_mm"))).sum())
    assert unpositioned > 0  # the case the issue found: readings logged before the slide had moved
    with output.open(newline="") as handle:
        body = list(csv.reader(handle))[1:]
    assert len(body) == readings
    assert sum(1 for row in body if math.isnan(float(row[1]))) == unpositioned
    sidecar = json.loads(output.with_name("steel.units.json").read_text())
    assert sidecar["rows"] == readings and sidecar["rows_without_position"] == unpositioned
    assert len(sidecar["direction"]) == readings


def test_the_export_message_says_how_many_readings_have_no_position(shipped_run, tmp_path, capsys):
    run = shipped_run(*STEEL).path
    assert main(["export", str(run), "-o", str(tmp_path / "x.csv")]) == 0
    line = capsys.readouterr().out.strip()
    points = read_run(run, transcripts=False)
    unpositioned = int((np.isfinite(points.column("ls_h")) & np.isnan(points.column("x_commanded_mm"))).sum())
    assert line.startswith(f"{int(np.isfinite(points.column('ls_h')).sum())} rows (one per reading) -> ")
    assert f"{unpositioned} of them taken before the slide had a position (x_mm = nan" in line


def test_the_csv_reads_back_the_run_files_readings_directions_and_station_figures(exported):
    run, output = exported
    from_run, from_csv = open_data(run), open_data(output)
    assert from_csv.sensor == from_run.sensor and from_csv.sensor.target == "steel"
    assert from_csv.sensor_note is None  # the sensor is known from the sidecar, not assumed
    a, b = from_run.data, from_csv.data
    assert len(a) == len(b)
    for name in ("x_m", "freq_hz", "t_coil_c", "t_target_c", "ls_h", "rs_ohm", "segment"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name), name)
    np.testing.assert_allclose(b.time_s, a.time_s, rtol=5e-15)  # the export writes 15 digits (storage/export.py)
    np.testing.assert_array_equal(b.direction, a.direction)
    np.testing.assert_array_equal(b.slide_repeatability_m, a.slide_repeatability_m)
    assert a.slide_repeatability_m.max() > 0


def _determined(params: dict) -> dict[str, float]:
    """Fitted parameters whose value is at least 3 standard errors from zero (the others are undetermined:
    a change of 1e-15 in the times can move them anywhere within their error)."""
    return {name: p["value"] for name, p in params.items()
            if p.get("stderr") and abs(p["value"]) > 3 * p["stderr"]}


def test_the_csv_is_analysed_as_its_run_file(exported):
    run, output = exported
    from_run, from_csv = open_data(run), open_data(output)
    fit_run = fit_summary(from_run.data, [], from_run.sensor)
    fit_csv = fit_summary(from_csv.data, [], from_csv.sensor)
    assert fit_csv["noise_ppm"] == pytest.approx(fit_run["noise_ppm"], rel=1e-9)
    assert fit_csv["noise_method"] == fit_run["noise_method"]
    for part in ("reading_ppm", "positioning_ppm"):  # positioning: from the declared repeatability, kept
        assert fit_csv["noise"][part] == pytest.approx(fit_run["noise"][part], rel=1e-9), part
    assert fit_run["noise"]["positioning_ppm"] > 0
    assert fit_csv["rmse_ppm"] == pytest.approx(fit_run["rmse_ppm"], rel=1e-9)
    determined = _determined(fit_run["params"])
    assert determined and _determined(fit_csv["params"]).keys() == determined.keys()
    for name, value in determined.items():
        assert fit_csv["params"][name]["value"] == pytest.approx(value, rel=1e-6), name
    found_run = diagnose(from_run.data, [], from_run.sensor)
    found_csv = diagnose(from_csv.data, [], from_csv.sensor)
    assert found_csv["verdict"] == found_run["verdict"]
    assert found_csv["claimed"] == found_run["claimed"]
    assert found_csv["noise_ppm"] == pytest.approx(found_run["noise_ppm"], rel=1e-9)


def test_a_csv_edited_after_the_export_is_refused_naming_its_sidecar(exported, tmp_path):
    _, output = exported
    edited = tmp_path / "steel.csv"
    edited.write_text("".join(output.read_text().splitlines(keepends=True)[:-3]))
    (tmp_path / "steel.units.json").write_text(output.with_name("steel.units.json").read_text())
    with pytest.raises(SidecarError, match=r"steel\.units\.json.*CSV has"):
        Measurements.from_csv(edited)


def test_a_hand_written_csv_without_a_sidecar_is_read_as_before(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text("time_s,x_mm,freq_hz,t_coil_c,t_target_c,ls_h,rs_ohm\n0,nan,500,25,25,1e-4,1\n"
                    "1,20,500,25,25,1e-4,1\n2,30,500,25,25,1.1e-4,1\n")
    data = Measurements.from_csv(path)
    assert len(data) == 2 and list(data.direction) == [1, 1] and not data.slide_repeatability_m.any()


def test_a_damaged_sidecar_is_one_line_naming_it(exported, tmp_path, capsys):
    _, output = exported
    copy = tmp_path / "steel.csv"
    copy.write_text(output.read_text())
    sidecar = tmp_path / "steel.units.json"
    for damage in ("{", '{"direction": "up"}', '{"station": {"slide_repeatability_m": -1}}',
                   '{"station": {"sensor": {"target": "gold"}}}'):
        sidecar.write_text(damage)
        assert main(["fit", str(copy)]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "steel.units.json" in err, err
