"""A line left waiting on the bridge link just before a reading is never stored as that reading (issue 24,
point 9): the run stores the true readings, and the stale line is in the transcript, the run file's notes,
the command line's output and the log; the recording still replays point for point."""

from __future__ import annotations

import logging

import numpy as np

from ecds_lab.cli import main
from ecds_lab.storage.reader import read_run
from ecds_lab.transports.transcript import STALE

SWEEP = "displacement_sweep.yaml"
#: Shaped like an XALL? reply (1 mH, 10 ohm), so only its arrival before the query tells it apart.
STALE_READING = "1.00000E-03,1.00000E+01,0"


def test_an_unsolicited_line_before_a_reading_is_reported_not_stored(
        tmp_path, experiments_dir, opened_stations, at_simulated_time, shipped_run, capsys, caplog):
    def inject() -> None:  # the moment the bridge is next triggered, a line arrives ahead of XALL?
        opened_stations[0].lab.faults.stale_lines["hm8118:*TRG"] = [STALE_READING]

    fired = at_simulated_time(100.0, inject)
    output = tmp_path / "stale.h5"
    with caplog.at_level(logging.WARNING, logger="ecds_lab"):
        assert main(["run", str(experiments_dir / SWEEP), "-o", str(output), "-q"]) == 0
    assert fired
    recorded = read_run(output)
    clean = read_run(shipped_run(SWEEP).path)
    assert recorded.status == "completed"
    np.testing.assert_array_equal(recorded.column("ls_h"), clean.column("ls_h"))  # every reading the true one
    assert not np.isclose(recorded.column("ls_h"), 1e-3).any()
    stale = [e for e in recorded.transcripts["bridge"] if e.kind == STALE]
    assert [e.text for e in stale] == [STALE_READING] and stale[0].clock_s >= fired[0]
    note = next(n for n in recorded.notes if n.startswith("bridge: 1 stale line(s)"))
    assert repr(STALE_READING) in note and "'XALL?'" in note
    assert f"note: {note}" in capsys.readouterr().err
    assert any(STALE_READING in r.getMessage() for r in caplog.records if r.name.startswith("ecds_lab"))
    assert main(["replay", str(output)]) == 0  # the stale line is discarded at the same place on replay
