"""The live view's look at a run file: rows, progress and ETA while written, a final state after the end."""

from __future__ import annotations

import os
import time

import numpy as np

from ecds_lab.live.server import make_server, url_of
from ecds_lab.live.snapshot import STALLED_AFTER_S, read_snapshot
from ecds_lab.storage.run_file import RunWriter, metadata_for


def test_a_missing_file_is_waited_for_and_a_finished_one_is_complete(tmp_path, shipped_run):
    assert read_snapshot(tmp_path / "not-yet.h5").status == "waiting for the run file"
    snap = read_snapshot(shipped_run("displacement_sweep.yaml").path).to_json()
    assert snap["status"] == "completed" and snap["rows"] == snap["expected_rows"] == snap["plotted_points"] == 248
    assert snap["remaining_s"] == 0.0 and snap["latest"]["ls_h"] > 0


def test_a_file_being_written_shows_progress_and_a_stalled_one_says_so(tmp_path, experiments_dir):
    experiment = (experiments_dir / "displacement_sweep.yaml").read_text()
    path = tmp_path / "live.h5"
    writer = RunWriter(path, metadata=metadata_for(experiment, "", "sweep", "displacement_sweep"), transcripts={})
    try:
        for i in range(40):
            writer.append({"time_s": 2.0 * i, "wall_time_s": 1000.0 + i, "step": 3 + i, "kind": 0, "point": i,
                           "x_commanded_mm": 20.0 + i // 4, "freq_hz": 500.0 if i % 4 < 2 else 15000.0,
                           "ls_h": 0.057})
        snap = read_snapshot(path).to_json()
        assert snap["status"] == "running" and snap["rows"] == 40 and snap["expected_rows"] == 248
        assert 0.1 < snap["fraction"] < 0.2 and snap["remaining_s"] > 0
        old = time.time() - STALLED_AFTER_S - 10
        os.utime(path, (old, old))
        stalled = read_snapshot(path)
        assert stalled.status == "stalled" and "--resume" in stalled.error
    finally:
        writer.close("completed")
    assert np.isfinite(read_snapshot(path).points[:, 0]).all()


def test_the_server_binds_to_localhost_on_a_free_port(tmp_path):
    server = make_server(tmp_path / "run.h5")
    try:
        assert url_of(server).startswith("http://127.0.0.1:") and server.server_address[1] > 0
    finally:
        server.server_close()
