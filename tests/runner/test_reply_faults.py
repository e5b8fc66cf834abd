"""A garbled reply never becomes data: the run re-queries once, or ends failed naming instrument, command, reply."""

from __future__ import annotations

import numpy as np

from ecds_lab.runner.session import run_experiment
from ecds_lab.storage.reader import read_run

SWEEP = "displacement_sweep.yaml"


def test_a_bridge_reply_cut_short_for_good_fails_the_run_keeping_the_good_points(
        tmp_path, experiments_dir, opened_stations, at_simulated_time, shipped_run):
    at_simulated_time(100.0, lambda: opened_stations[0].lab.faults.short_replies.update({"hm8118:XALL?": -1}))
    output = tmp_path / "cut.h5"
    result = run_experiment(experiments_dir / SWEEP, None, output, progress=False)
    assert result.status == "failed"
    assert result.error.startswith("ReplyFormatError: bridge: command 'XALL?' failed with reply ")
    recorded = read_run(output)
    assert recorded.status == "failed" and recorded.metadata["error"] == result.error
    kept = recorded.column("rs_ohm")
    assert 0 < len(kept)
    full = read_run(shipped_run(SWEEP).path).column("rs_ohm")
    np.testing.assert_allclose(kept, full[:len(kept)], rtol=1e-9)  # every stored reading is a whole one


def test_occasional_cut_and_extra_lines_are_recovered_and_the_run_completes(
        tmp_path, experiments_dir, opened_stations, at_simulated_time):
    def garble() -> None:
        faults = opened_stations[0].lab.faults
        faults.short_replies.update({"hm8118:XALL?": 1, "daq970a:READ?": 1})
        faults.unsolicited_lines["hm8118"] = ["OVLD"]

    at_simulated_time(100.0, garble)
    output = tmp_path / "recovered.h5"
    result = run_experiment(experiments_dir / SWEEP, None, output, progress=False)
    assert result.status == "completed", result.error
    recorded = read_run(output)
    assert np.isfinite(recorded.column("rs_ohm")).all()
    assert recorded.column("rs_ohm").min() > 0.5 * np.nanmedian(recorded.column("rs_ohm"))
