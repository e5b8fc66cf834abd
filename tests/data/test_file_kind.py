"""``file_kind``: what a DATA file is, decided by its content (run file, CSV, or a clear error)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from ecds_lab.data.files import file_kind
from ecds_lab.data.measurements import DataError, Measurements
from ecds_lab.data.sensor import DEFAULT_SENSOR_NOTE
from ecds_lab.storage.data_file import open_data

SWEEP = Path(__file__).resolve().parent / "sessions" / "sweep.h5"
EXCEL_CSV = ("\ufefftime_s,x_mm,freq_hz,t_coil_c,t_target_c,ls_h,rs_ohm\r\n"
             "0.0,20.0,15000,22.5,22.0,0.0512,98.5\r\n"
             "1.5,inf,500,22.6,22.0,0.0570,51.0\r\n")


def test_a_run_file_is_a_run_file():
    assert file_kind(SWEEP) == "run"


def test_a_run_file_is_recognised_by_its_content_not_its_name(tmp_path):
    renamed = tmp_path / "sweep.dat"
    renamed.write_bytes(SWEEP.read_bytes())
    assert file_kind(renamed) == "run"
    assert len(open_data(renamed).data) == len(open_data(SWEEP).data) > 0


def test_an_exported_csv_is_a_csv_and_reads_back_the_same(tmp_path):
    data = open_data(SWEEP).data
    csv = tmp_path / "sweep.csv"
    data.to_csv(csv)
    assert file_kind(csv) == "csv"
    again = open_data(csv)
    assert again.kind == "csv" and again.run is None
    np.testing.assert_array_equal(again.data.ls_h, data.ls_h)


def test_an_excel_csv_with_a_byte_order_mark_is_read(tmp_path):
    csv = tmp_path / "excel.csv"
    csv.write_bytes(EXCEL_CSV.encode("utf-8"))
    assert file_kind(csv) == "csv"
    data = Measurements.from_csv(csv)
    np.testing.assert_array_equal(data.time_s, [0.0, 1.5])
    np.testing.assert_array_equal(data.ls_h, [0.0512, 0.0570])
    assert data.x_m[0] == pytest.approx(0.020) and np.isinf(data.x_m[1])


def test_a_csv_records_no_sensor_and_says_so(tmp_path):
    csv = tmp_path / "excel.csv"
    csv.write_bytes(EXCEL_CSV.encode("utf-8"))
    opened = open_data(csv)
    assert (opened.sensor.target, opened.sensor_source, opened.sensor_note) == ("copper", "not recorded",
                                                                                 DEFAULT_SENSOR_NOTE)
    overridden = open_data(csv, "steel_target")
    assert overridden.sensor.target == "steel" and overridden.sensor_note is None


@pytest.mark.parametrize(("name", "content", "message"), [
    ("junk.bin", bytes(range(256)) * 4, "neither an ecds-lab run file (HDF5) nor a CSV"),
    ("notes.csv", b"hello,world\n1,2\n", "missing time_s, x_mm, freq_hz"),
    ("empty.csv", b"", "missing time_s"),
    ("text.h5", b"time_s,x_mm\n", "not an HDF5 file, so not an ecds-lab run file"),
])
def test_anything_else_is_refused_naming_the_file(tmp_path, name, content, message):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(DataError, match=re.escape(message)) as raised:
        file_kind(path)
    assert str(raised.value).startswith(f"{path}: ")
    with pytest.raises(DataError, match=re.escape(message)):
        open_data(path)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(DataError, match=f"{tmp_path / 'nothing.csv'}: no such file"):
        file_kind(tmp_path / "nothing.csv")


@pytest.mark.parametrize(("separator", "named"), [(";", "semicolons"), ("\t", "tabs")])
def test_a_csv_separated_otherwise_than_by_commas_is_named_so(tmp_path, separator, named):
    """A spreadsheet set to a decimal comma writes semicolons: the error said every import column was missing."""
    lines = EXCEL_CSV.removeprefix("\ufeff").splitlines()
    rows = [line.replace(",", separator) if i == 0 else line.replace(",", separator).replace(".", ",")
            for i, line in enumerate(lines)]
    path = tmp_path / "euro.csv"
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(DataError, match=f"separated by {named}, not by commas") as error:
        file_kind(path)
    assert "missing" not in str(error.value)
