"""``replay_run`` / ``ecds-lab replay``: re-execute a run against its transcripts and compare the data.

A fresh simulated run reproduces exactly; a driver changed to send one different command is
caught with the divergence message; unreadable run files give one clean line and exit code 2.
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from ecds_lab.cli import main
from ecds_lab.data.columns import INDEX
from ecds_lab.drivers.hm8118 import HM8118
from ecds_lab.drivers.hmp import HMP4040
from ecds_lab.errors import RunFileError
from ecds_lab.replay import compare_points, format_replay, replay_run
from ecds_lab.runner.session import run_experiment
from ecds_lab.storage.reader import read_run

ROOT = Path(__file__).resolve().parents[2]
SESSIONS = ROOT / "tests" / "data" / "sessions"


# -- a fresh run reproduces exactly ------------------------------------------------------------
def test_a_fresh_simulated_run_replays_exactly(fresh_sweep, capsys):
    result = replay_run(fresh_sweep)
    assert result.reproduced, result.differences
    assert (result.original_status, result.replay_status) == ("completed", "completed")
    assert result.original_points == result.replayed_points == 20
    assert main(["replay", str(fresh_sweep)]) == 0
    out = capsys.readouterr().out
    assert out == (f"{fresh_sweep}: recorded 20 rows (completed), replayed 20 (completed)\n"
                   "reproduced: every row equal\n")


def test_a_run_file_with_per_role_transcripts_replays_exactly(fresh_sweep, tmp_path, per_role_transcripts,
                                                               as_real_lab_recording, capsys):
    """Files written before the transcript log (one events/text group per role) keep replaying."""
    old = per_role_transcripts(Path(shutil.copyfile(fresh_sweep, tmp_path / "per-role.h5")))
    with h5py.File(old, "r") as f:
        assert "log" not in f["entry/transcripts"] and "events" in f["entry/transcripts/bridge"]
    assert read_run(old).transcripts == read_run(fresh_sweep).transcripts
    result = replay_run(old)
    assert result.reproduced, result.differences
    assert result.replayed_points == result.original_points == 20
    assert main(["replay", str(old)]) == 0
    assert "reproduced: every row equal" in capsys.readouterr().out
    with h5py.File(old, "a") as f:  # and as a real-lab recording (wall-clock transcript times)
        as_real_lab_recording(f)
    assert min(events[0].clock_s for events in read_run(old).transcripts.values() if events) > 1e6
    assert replay_run(old).reproduced


def test_a_fresh_run_with_wall_clock_transcript_times_replays(fresh_sweep, tmp_path, as_real_lab_recording):
    """The transcript log of a run made now, edited as a real lab's recording would be (monotonic times)."""
    path = Path(shutil.copyfile(fresh_sweep, tmp_path / "real-lab.h5"))
    with h5py.File(path, "a") as f:
        assert "log" in f["entry/transcripts"]
        as_real_lab_recording(f)
    recorded = read_run(path)
    assert min(events[0].clock_s for events in recorded.transcripts.values() if events) > 1e6
    result = replay_run(path)
    assert result.reproduced, result.differences
    assert result.replay_status == recorded.status == "completed"


# -- a changed driver is caught -------------------------------------------------------------------
def _first_position(path: Path, role: str, command: str) -> tuple[int, int]:
    """1-based transcript position of the first time ``command`` was sent, and the transcript's length."""
    events = read_run(path).transcripts[role]
    return next(i for i, e in enumerate(events, 1) if e.kind == "sent" and e.text == command), len(events)


def test_a_driver_sending_one_different_command_is_caught(fresh_sweep, monkeypatch, capsys, caplog):
    monkeypatch.setattr(HM8118.frequency_hz, "set_command", "FREQ {:.1f}")  # 'FREQ 500.0' instead of 'FREQ 500'
    position, total = _first_position(fresh_sweep, "bridge", "FREQ 500")
    divergence = (f"bridge: replay diverges at transcript event {position} of {total}: "
                  f"expected command 'FREQ 500', got command 'FREQ 500.0'")

    result = replay_run(fresh_sweep)
    assert not result.reproduced
    assert result.divergence == divergence
    assert result.replay_status == "failed" and result.replayed_points == 0

    with caplog.at_level(logging.DEBUG):
        assert main(["replay", str(fresh_sweep)]) == 1
    captured = capsys.readouterr()
    assert "NOT reproduced" in captured.out
    assert f"diverged: {divergence}" in captured.out
    assert captured.out.count("replay diverges") == 1  # the first divergence only, not its consequences
    # the runner's safe-state warnings are about a lab that is not there: not shown during a replay
    assert "SWITCH IT OFF" not in captured.err + captured.out + caplog.text
    assert "Traceback" not in captured.err


def test_a_changed_measurement_sequence_is_caught(fresh_sweep, monkeypatch, capsys):
    """HM8118.measure without its *WAI: the recording has '*WAI' where the driver now asks 'XALL?'."""
    real_write = HM8118.write

    def write(self, command: str) -> None:
        if command != "*WAI":
            real_write(self, command)

    monkeypatch.setattr(HM8118, "write", write)
    position, total = _first_position(fresh_sweep, "bridge", "*WAI")
    assert main(["replay", str(fresh_sweep)]) == 1
    out = capsys.readouterr().out
    assert (f"bridge: replay diverges at transcript event {position} of {total}: "
            f"expected command '*WAI', got command 'XALL?'") in out


def test_a_divergence_while_identifying_is_reported_not_raised(fresh_sweep, monkeypatch, capsys):
    monkeypatch.setattr(HM8118, "identity", lambda self: self.ask("*IDN ?"))
    result = replay_run(fresh_sweep)
    assert not result.reproduced
    assert result.divergence == ("bridge: replay diverges at transcript event 1 of "
                                 f"{len(read_run(fresh_sweep).transcripts['bridge'])}: "
                                 "expected command '*IDN?', got command '*IDN ?'")
    assert main(["replay", str(fresh_sweep)]) == 1
    assert "expected command '*IDN?', got command '*IDN ?'" in capsys.readouterr().out


def test_a_driver_that_leaves_recorded_commands_unsent_is_not_reproduced(fresh_sweep, monkeypatch, capsys):
    """The heater skips verifying its switch-off: no command differs, but the recording is not used up."""
    monkeypatch.setattr(HMP4040, "verify_off", lambda self, outputs: None)
    result = replay_run(fresh_sweep)
    assert not result.reproduced
    total = len(read_run(fresh_sweep).transcripts["heater"])
    unsent = 2 + 2 * 5  # OUTP:GEN? and its reply; per heater output INST, OUTP? and MEAS:CURR? with their replies
    assert result.differences == [f"heater: replay ended at transcript event {total - unsent + 1} of {total}; "
                                   f"the recording continues with command 'OUTP:GEN?'"]
    assert main(["replay", str(fresh_sweep)]) == 1
    assert "NOT reproduced" in capsys.readouterr().out


def test_changed_data_are_reported_row_and_column(fresh_sweep):
    points = read_run(fresh_sweep).points
    changed = points.copy()
    changed[3, INDEX["ls_h"]] *= 1.001
    assert compare_points(points, points) == []
    assert compare_points(points, changed) == [f"row 3, ls_h: recorded {points[3, INDEX['ls_h']]!r}, "
                                               f"replayed {changed[3, INDEX['ls_h']]!r}"]
    assert compare_points(points, changed[:-1])[0] == f"row count: recorded {len(points)}, replayed {len(points) - 1}"


def test_format_replay_summarises_a_difference(fresh_sweep, monkeypatch):
    monkeypatch.setattr(HM8118.frequency_hz, "set_command", "FREQ {:.1f}")
    text = format_replay(replay_run(fresh_sweep))
    assert text.splitlines()[:3] == [
        f"{fresh_sweep}: recorded 20 rows (completed), replayed 0 (failed)", "NOT reproduced:",
        text.splitlines()[2]]
    assert text.splitlines()[2].startswith("  diverged: bridge: replay diverges at transcript event")


# -- unreadable files: one clean line, exit code 2 ---------------------------------------------------
def _truncated_half(path: Path) -> None:
    data = (SESSIONS / "sweep.h5").read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _truncated_tail(path: Path) -> None:
    data = (SESSIONS / "sweep.h5").read_bytes()
    path.write_bytes(data[: len(data) * 9 // 10])


def _random_bytes(path: Path) -> None:
    path.write_bytes(os.urandom(8192))


def _random_after_superblock(path: Path) -> None:
    data = bytearray((SESSIONS / "sweep.h5").read_bytes())
    data[2048:] = os.urandom(len(data) - 2048)
    path.write_bytes(bytes(data))


def _text_file(path: Path) -> None:
    path.write_text("time_s,x_mm,freq_hz\n0,20,500\n")


def _hdf5_without_entry(path: Path) -> None:
    with h5py.File(path, "w") as f:
        f["data"] = [1.0, 2.0]


def _edited(edit):
    def make(path: Path) -> None:
        path.write_bytes((SESSIONS / "sweep.h5").read_bytes())
        with h5py.File(path, "a") as f:
            edit(f)
    return make


CORRUPT = {
    "truncated-half": (_truncated_half, "truncated"),
    "truncated-tail": (_truncated_tail, "truncated"),
    "random-bytes": (_random_bytes, "cannot read the run file"),
    "random-after-superblock": (_random_after_superblock, "cannot read the run file"),
    "not-hdf5": (_text_file, "cannot read the run file"),
    "hdf5-without-entry": (_hdf5_without_entry, "not an ecds-lab run file"),
    "no-transcripts": (_edited(lambda f: f["entry"].__delitem__("transcripts")), "no transcripts"),
    "no-experiment": (_edited(lambda f: f["entry"].attrs.__delitem__("experiment_yaml")),
                      "no experiment configuration recorded"),
    "broken-experiment-yaml": (_edited(lambda f: f["entry"].attrs.__setitem__("experiment_yaml", "kind: [sweep")),
                               "recorded experiment configuration (experiment_yaml) is not valid YAML"),
    "broken-station-yaml": (_edited(lambda f: f["entry"].attrs.__setitem__("station_yaml", "bridge: {driver")),
                            "recorded station configuration (station_yaml) is not valid YAML"),
}


@pytest.mark.parametrize("kind", list(CORRUPT))
def test_an_unreadable_run_file_gives_a_clear_message_and_exit_code_2(kind, tmp_path, capsys):
    make, message = CORRUPT[kind]
    path = tmp_path / f"{kind}.h5"
    make(path)
    with pytest.raises(RunFileError, match=re.escape(message)):
        replay_run(path)
    assert main(["replay", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith(f"ecds-lab replay: {path}: ") and message in captured.err
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err


def test_a_missing_run_file(tmp_path, capsys):
    assert main(["replay", str(tmp_path / "nothing.h5")]) == 2
    assert capsys.readouterr().err == f"ecds-lab replay: {tmp_path / 'nothing.h5'}: no such run file\n"


@pytest.mark.parametrize("kind", ["truncated-half", "random-after-superblock"])
def test_the_command_fails_promptly_without_traceback_on_a_damaged_file(kind, tmp_path):
    """Through the installed command, in a process of its own (a damaged file once made the reader spin)."""
    make, message = CORRUPT[kind]
    path = tmp_path / f"{kind}.h5"
    make(path)
    command = [sys.executable, "-c", "import sys; from ecds_lab.cli import main; sys.exit(main())", "replay", str(path)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert message in done.stderr and "Traceback" not in done.stderr


def test_a_resumed_run_cannot_be_replayed_and_says_so(tmp_path, capsys):
    """A resumed run holds two sessions (its predecessor's transcripts, then its own)."""
    experiment, station = SESSIONS / "instrument_error.yaml", SESSIONS / "station_bridge_error.yaml"
    first = run_experiment(experiment, station, tmp_path / "first.h5", progress=False)
    assert first.status == "failed"
    resumed = run_experiment(experiment, station, tmp_path / "resumed.h5", resume=first.path, progress=False)
    assert read_run(resumed.path).metadata["resumed_from"] == str(first.path)
    assert main(["replay", str(resumed.path)]) == 2
    err = capsys.readouterr().err
    assert err == (f"ecds-lab replay: {resumed.path}: a resumed run holds two sessions; "
                   "replay the original run file instead\n")
    assert replay_run(first.path).reproduced  # the original replays
