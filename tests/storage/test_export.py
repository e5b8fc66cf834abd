"""`ecds-lab export`: every column, units in a sidecar, shortest exact numbers, and the file re-imports."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from ecds_lab.cli import main
from ecds_lab.data.columns import INDEX, UNITS
from ecds_lab.data.measurements import CSV_COLUMNS, Measurements
from ecds_lab.storage.export import ALL_COLUMNS, number
from ecds_lab.storage.reader import read_run


@pytest.mark.parametrize("value", [22.34, 22.340000000000003, 0.1 + 0.2, 1e-4, 123456.789e-12, -0.5, 3.0,
                                   float("inf"), 2.5e300, 6.739999999999998, 1795442683.8988607])
def test_numbers_drop_float_noise_and_round_trip(value):
    text = number(value)
    assert (float(text) == value or abs(float(text) - value) <= 5e-15 * abs(value)) and len(text) <= len(repr(value))
    assert number(float(text)) == text  # written, read, written again: the same text
    assert float(text) == value or len(repr(value).replace("-", "").replace(".", "").lstrip("0")) > 15


def test_the_noise_the_issue_names_is_gone():
    assert (number(22.340000000000003), number(0.1 + 0.2), number(3.0), number(22.34)) == ("22.34", "0.3", "3", "22.34")


def test_export_writes_every_column_with_a_units_sidecar_and_re_imports(shipped_run, tmp_path):
    path = shipped_run("coil_heating.yaml").path
    output = tmp_path / "run.csv"
    assert main(["export", str(path), "-o", str(output)]) == 0
    with output.open(newline="") as handle:
        rows = list(csv.reader(handle))
    header, body = rows[0], rows[1:]
    assert tuple(header[:7]) == CSV_COLUMNS and len(header) == 19 == len(set(header))
    sidecar = json.loads((tmp_path / "run.units.json").read_text())
    assert sidecar["columns"]["ls_h"]["unit"] == "H" and sidecar["columns"]["x_mm"]["unit"] == "mm"
    assert sidecar["columns"]["coil_heater_w"]["unit"] == UNITS["coil_heater_w"] and sidecar["rows"] == len(body)
    # readings parsed from instrument text come back exactly; computed ones to 1e-15; no 16-17 digit noise
    table = read_run(path, transcripts=False).points
    for name in ("t_coil_c", "ls_h", "rs_ohm"):
        np.testing.assert_array_equal([float(r[header.index(name)]) for r in body], table[:, INDEX[name]], name)
    for name in ("time_s", "wall_time_s", "coil_heater_w"):
        np.testing.assert_allclose([float(r[header.index(name)]) for r in body], table[:, INDEX[name]], rtol=5e-15)
    assert not any(s in cell for row in body for cell in row for s in ("0000000000", "9999999999"))
    imported = Measurements.from_csv(output)
    assert len(imported) == len(body) and np.isinf(imported.x_m).all()


def test_export_columns_picks_and_unknown_names_are_refused(shipped_run, tmp_path, capsys):
    path = shipped_run("displacement_sweep.yaml").path
    output = tmp_path / "few.csv"
    assert main(["export", str(path), "-o", str(output), "--columns", "x_mm,ls_h,x_readback_mm"]) == 0
    assert output.read_text().splitlines()[0] == "x_mm,ls_h,x_readback_mm"
    assert main(["export", str(path), "-o", str(output), "--columns", "x_mm,volts"]) == 2
    err = capsys.readouterr().err
    assert "volts" in err and all(name in err for name in ALL_COLUMNS)
