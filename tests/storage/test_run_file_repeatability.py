"""The slide's declared repeatability in the run file: /entry/@slide_repeatability_m (metres), read back
into the run's metadata and every reading; absent (older files, CSV) it is 0 and nothing changes."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from ecds_lab.data.columns import COLUMN_NAMES
from ecds_lab.data.measurements import Measurements
from ecds_lab.errors import RunFileError
from ecds_lab.storage.data_file import open_data
from ecds_lab.storage.run_file import RunWriter, metadata_for

SWEEP = "displacement_sweep.yaml"


def test_a_run_records_its_stations_repeatability_in_metres_and_reads_it_back(shipped_run):
    path = shipped_run(SWEEP).path  # the default station, the simulated lab, declares 5 um
    with h5py.File(path, "r") as f:
        assert float(f["entry"].attrs["slide_repeatability_m"]) == pytest.approx(5e-6, rel=1e-12)
    opened = open_data(path)
    assert opened.run is not None and opened.run.slide_repeatability_m == pytest.approx(5e-6, rel=1e-12)
    np.testing.assert_allclose(opened.data.slide_repeatability_m, np.full(len(opened.data), 5e-6), rtol=1e-12)
    half = opened.data.select(np.arange(len(opened.data)) % 2 == 0)
    assert len(half.slide_repeatability_m) == len(half)


def _written(path, **metadata) -> None:
    writer = RunWriter(path, metadata=metadata_for("kind: x\n", "name: s\n", "t", "displacement_sweep", **metadata),
                       transcripts={})
    for point in range(3):
        row = {name: float(point) for name in COLUMN_NAMES}
        row.update(x_commanded_mm=20.0 + point, ls_h=0.05, direction=1.0, freq_hz=15000.0)
        writer.append(row)
    writer.close("completed")


def test_a_station_without_a_declaration_records_none_and_reads_as_zero(tmp_path):
    path = tmp_path / "plain.h5"
    _written(path)
    with h5py.File(path, "r") as f:
        assert "slide_repeatability_m" not in f["entry"].attrs
    opened = open_data(path)
    assert opened.run is not None and opened.run.slide_repeatability_m == 0.0
    assert not opened.data.slide_repeatability_m.any()


def test_a_recorded_file_from_before_the_attribute_reads_as_zero():
    opened = open_data("tests/data/sessions/sweep.h5")
    assert opened.run is not None and opened.run.slide_repeatability_m == 0.0
    assert len(opened.data) and not opened.data.slide_repeatability_m.any()


def test_a_damaged_attribute_is_refused_naming_it(tmp_path):
    path = tmp_path / "bad.h5"
    _written(path, slide_repeatability_um=2.0)
    with h5py.File(path, "a") as f:
        assert f["entry"].attrs["slide_repeatability_m"] == repr(2.0e-6)
        f["entry"].attrs["slide_repeatability_m"] = "-3e-6"
    with pytest.raises(RunFileError, match=r"slide_repeatability_m = '-3e-6' is not a repeatability in metres"):
        open_data(path)


def test_joined_files_keep_each_files_repeatability_and_csv_has_none(tmp_path):
    declared, plain = tmp_path / "declared.h5", tmp_path / "plain.h5"
    _written(declared, slide_repeatability_um=5.0)
    _written(plain)
    csv = tmp_path / "plain.csv"
    open_data(plain).data.to_csv(csv)
    parts = [open_data(p).data for p in (declared, plain, csv)]
    joined = Measurements.concatenate(parts)
    np.testing.assert_allclose(joined.slide_repeatability_m, [5e-6] * 3 + [0.0] * 6, rtol=1e-12, atol=0)
