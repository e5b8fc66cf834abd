"""The HDF5 run file: NeXus layout, units, metadata, per-point flushing, the reader, and `ecds-lab export`."""

from __future__ import annotations

from datetime import datetime

import h5py
import numpy as np
import pytest

from ecds_lab import __version__
from ecds_lab.cli import main
from ecds_lab.data.columns import COLUMN_NAMES, COLUMNS, INDEX, PLANNED_POINT
from ecds_lab.data.measurements import CSV_COLUMNS, Measurements
from ecds_lab.errors import RunFileError
from ecds_lab.runner.session import run_experiment
from ecds_lab.station import DEFAULT_STATION, load_station_config, open_station
from ecds_lab.storage.reader import read_measurements, read_run
from ecds_lab.storage.run_file import RunWriter, metadata_for
from ecds_lab.transports.transcript import Transcript

SWEEP = "displacement_sweep.yaml"


@pytest.fixture
def sweep_file(shipped_run):
    return shipped_run(SWEEP).path


def test_nxdata_columns_carry_units_and_match_the_points_table(sweep_file):
    with h5py.File(sweep_file, "r") as f:
        entry = f["entry"]
        assert entry.attrs["NX_class"] == "NXentry"
        data = entry["data"]  # every column; @default is the per-kind plot (tests/storage/test_nexus.py)
        assert data.attrs["NX_class"] == "NXdata"
        assert set(data) == set(COLUMN_NAMES)
        assert data.attrs["signal"] in data and all(axis in data for axis in data.attrs["axes"])
        table = entry["points"][()]
        assert list(entry["points"].attrs["units"]) == [c.unit for c in COLUMNS]
        for column in COLUMNS:
            assert data[column.name].attrs["units"] == column.unit, column.name
            np.testing.assert_array_equal(data[column.name][()], table[:, INDEX[column.name]])
        assert data["ls_h"].attrs["units"] == "H" and data["x_commanded_mm"].attrs["units"] == "mm"


def test_thermocouples_are_nxlogs_of_the_recorded_temperatures(sweep_file):
    with h5py.File(sweep_file, "r") as f:
        table = f["entry/points"][()]
        thermocouples = f["entry/instrument/thermocouples"]
        assert set(thermocouples) == {"coil", "target", "ambient"}
        for name, log in thermocouples.items():
            assert log.attrs["NX_class"] == "NXlog"
            assert (log["time"].attrs["units"], log["value"].attrs["units"]) == ("s", "degC")
            np.testing.assert_array_equal(log["time"][()], table[:, INDEX["time_s"]])
            np.testing.assert_array_equal(log["value"][()], table[:, INDEX[f"t_{name}_c"]])
            assert np.isfinite(log["value"][()]).all()


def test_metadata_holds_the_yaml_as_given_identities_version_times_status_and_note(tmp_path, experiments_dir):
    text = (experiments_dir / SWEEP).read_text().replace("sweep:\n", "operator_note: 'new cable, bench 2'  # hi\n"
                                                        "sweep:\n", 1)
    text = text.replace("positions_mm: [", "positions_mm: [  30.0,   ", 1)  # odd spacing must survive
    experiment = tmp_path / "noted.yaml"
    experiment.write_text(text)
    output = tmp_path / "noted.h5"
    result = run_experiment(experiment, None, output, progress=False)
    assert result.status == "completed"

    with h5py.File(output, "r") as f:
        entry = f["entry"]
        attrs = {k: v for k, v in entry.attrs.items()}
        identities = {role: group.attrs["identity"] for role, group in entry["instrument"].items()
                      if "identity" in group.attrs}
    assert attrs["experiment_yaml"] == text
    assert attrs["station_yaml"] == DEFAULT_STATION.read_text()
    assert attrs["operator_note"] == "new cable, bench 2"
    assert attrs["software"] == f"ecds-lab {__version__}"
    assert attrs["status"] == "completed" and attrs["kind"] == "displacement_sweep"
    start, end = datetime.fromisoformat(attrs["start_time"]), datetime.fromisoformat(attrs["end_time"])
    assert start <= end and start.tzinfo is not None
    config, yaml_text = load_station_config(None)
    station = open_station(config, yaml_text)
    try:
        assert identities == station.identify()
    finally:
        station.close()


def test_every_point_is_on_disk_before_the_file_is_closed(tmp_path):
    path = tmp_path / "live.h5"
    transcript = Transcript("bridge")
    writer = RunWriter(path, metadata=metadata_for("kind: x\n", "name: s\n", "live", "displacement_sweep"),
                       transcripts={"bridge": transcript})
    rows = []
    for point in range(3):
        row = {name: float(i + 10 * point) for i, name in enumerate(COLUMN_NAMES)}
        row.update(kind=PLANNED_POINT, point=point)
        writer.append(row)
        rows.append([row[name] for name in COLUMN_NAMES])
        live = read_run(path)  # as a viewer (or a crashed writer's successor) would see it
        assert live.status == "interrupted"
        np.testing.assert_array_equal(live.points, rows)
    transcript.record(1.0, "sent", "*IDN?")
    writer.close("completed")
    done = read_run(path)
    assert done.status == "completed" and done.completed_points() == {0, 1, 2}
    assert [e.text for e in done.transcripts["bridge"]] == ["*IDN?"]
    with pytest.raises(RunFileError, match="exists"):
        RunWriter(path, metadata={}, transcripts={})


def _writer(path, **transcripts):
    return RunWriter(path, metadata=metadata_for("kind: x\n", "name: s\n", "t", "displacement_sweep"),
                     transcripts=transcripts)


def test_rows_across_chunk_boundaries_read_back_exactly_and_missing_columns_are_nan(tmp_path):
    path = tmp_path / "blocks.h5"
    writer = _writer(path)
    block = np.arange(45 * len(COLUMNS), dtype=float).reshape(45, len(COLUMNS))
    writer.append_rows(block[:7])  # a resumed run's copy: blocks that start, end and span chunks
    for row in block[7:40]:
        writer.append(dict(zip(COLUMN_NAMES, row, strict=True)))
    writer.append_rows(block[40:])
    writer.append({"time_s": 99.0, "ls_h": 1e-4})
    live = read_run(path).points
    np.testing.assert_array_equal(live[:45], block)
    assert live[45, INDEX["time_s"]] == 99.0 and live[45, INDEX["ls_h"]] == 1e-4
    assert np.isnan(np.delete(live[45], [INDEX["time_s"], INDEX["ls_h"]])).all()
    writer.close("completed")
    np.testing.assert_array_equal(read_run(path).points, live)


def test_an_unknown_column_is_refused_by_name_and_nothing_is_written(tmp_path):
    writer = _writer(tmp_path / "bad.h5")
    with pytest.raises(RunFileError, match="ls_mh"):
        writer.append({"time_s": 1.0, "ls_mh": 0.1})
    assert writer.rows == 0
    writer.close("failed")


def test_a_row_grown_but_never_written_is_not_a_point(tmp_path):
    """A kill between growing the table and writing the row leaves a fill-value (NaN) row behind."""
    path = tmp_path / "killed.h5"
    writer = _writer(path)
    writer.append({name: 1.0 for name in COLUMN_NAMES})
    writer._points.id.set_extent((2, len(COLUMNS)))
    writer._points.id.flush()
    assert read_run(path).points.shape == (1, len(COLUMNS))


def test_reader_api(sweep_file):
    run = read_run(sweep_file)
    assert run.status == "completed"
    assert run.points.shape == (int(run.metadata["points"]), len(COLUMN_NAMES))
    table = run.table()
    assert list(table) == list(COLUMN_NAMES)
    np.testing.assert_array_equal(table["ls_h"], run.column("ls_h"))
    assert run.completed_points() == set(range(int(run.metadata["planned_points"])))
    assert set(run.transcripts) == {"bridge", "slide", "scanner", "heater"}
    assert all(run.transcripts[role] for role in run.transcripts)
    with pytest.raises(KeyError, match="ls_h"):
        run.column("inductance")
    measurements = read_measurements(sweep_file)
    assert len(measurements) == len(run.points)
    np.testing.assert_array_equal(measurements.x_m, run.column("x_commanded_mm") * 1e-3)


def test_reader_refuses_missing_foreign_and_truncated_files(tmp_path, sweep_file):
    with pytest.raises(RunFileError, match="no such run file"):
        read_run(tmp_path / "missing.h5")
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["data"] = [1, 2, 3]
    with pytest.raises(RunFileError, match=f"{foreign}: not an ecds-lab run file"):
        read_run(foreign)
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(sweep_file.read_bytes()[:2000])
    with pytest.raises(RunFileError, match=str(truncated)):
        read_run(truncated)


@pytest.mark.parametrize("experiment", [SWEEP, "coil_heating.yaml"])
def test_export_writes_the_csv_import_format(experiment, shipped_run, tmp_path, capsys):
    path = shipped_run(experiment).path
    csv_path = tmp_path / "run.csv"
    assert main(["export", str(path), "-o", str(csv_path)]) == 0
    assert csv_path.read_text().splitlines()[0].startswith(",".join(CSV_COLUMNS) + ",")  # then the other columns
    exported, recorded = Measurements.from_csv(csv_path), read_measurements(path)
    assert len(exported) == len(recorded) > 0
    assert capsys.readouterr().out.startswith(f"{len(recorded)} rows")
    for name in ("freq_hz", "t_coil_c", "t_target_c", "ls_h", "rs_ohm"):
        np.testing.assert_array_equal(getattr(exported, name), getattr(recorded, name), err_msg=name)
    # computed times lose only their float noise (16th-17th digit; storage/export.py)
    np.testing.assert_allclose(exported.time_s, recorded.time_s, rtol=5e-15, atol=0)
    # x goes m -> mm -> m through the CSV: equal to the last bit or one ulp off, never more
    np.testing.assert_allclose(exported.x_m, recorded.x_m, rtol=4e-16, atol=0)
    run = read_run(path, transcripts=False)
    in_air = ~np.isfinite(run.column("x_commanded_mm"))
    assert np.isinf(exported.x_m).sum() == in_air.sum()
