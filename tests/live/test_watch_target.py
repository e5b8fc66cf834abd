"""`ecds-lab watch` on a CSV or a mistyped path fails at once with one line; a run file that does not exist
yet is waited for a bounded, announced time (issue 24, point 7; docs/live_view.md)."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from ecds_lab.cli import main
from ecds_lab.errors import RunFileError
from ecds_lab.live.target import check_watch_target, wait_for_run_file


def one_error_line(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    started = time.monotonic()
    assert main(["watch", *argv]) == 2
    assert time.monotonic() - started < 5  # at once, not after a wait
    err = capsys.readouterr().err.strip()
    assert "\n" not in err, err
    return err


def test_a_csv_is_refused_at_once(tmp_path, capsys):
    csv = tmp_path / "run.csv"
    csv.write_text("time_s,x_mm,freq_hz,t_coil_c,t_target_c,ls_h,rs_ohm\n0,20,500,25,25,1e-4,1\n")
    err = one_error_line(capsys, str(csv))
    assert "run.csv" in err and "a CSV, not a run file" in err


def test_a_path_in_a_folder_that_does_not_exist_is_refused_at_once(tmp_path, capsys):
    err = one_error_line(capsys, str(tmp_path / "typo" / "run.h5"))
    assert "typo" in err and "does not exist" in err


def test_a_name_that_is_no_run_files_is_refused_at_once(tmp_path, capsys):
    err = one_error_line(capsys, str(tmp_path / "run.hf5"))
    assert "run.hf5" in err and ".h5" in err


def test_a_folder_is_refused_at_once(tmp_path, capsys):
    assert "a folder" in one_error_line(capsys, str(tmp_path))


def test_a_run_file_not_created_in_time_ends_the_watch_saying_what_it_waited_for(tmp_path):
    path = tmp_path / "later.h5"
    done = subprocess.run([sys.executable, "-m", "ecds_lab.cli", "watch", str(path), "--wait", "0.5"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "http://127.0.0.1:" in done.stdout and f"waiting up to 0.5 s for {path}" in done.stdout
    assert done.stderr.strip().count("\n") == 0 and "not created within 0.5 s" in done.stderr


def test_the_wait_ends_when_the_run_creates_its_file(tmp_path):
    path = tmp_path / "run.h5"
    assert check_watch_target(path) is False
    clock = [0.0]

    def sleep(seconds: float) -> None:
        clock[0] += seconds
        if clock[0] >= 3.0:
            path.write_bytes(b"")

    wait_for_run_file(path, 10.0, sleep=sleep, now=lambda: clock[0])
    assert 3.0 <= clock[0] < 4.0
    assert check_watch_target(path) is True  # an empty file is a run file being created
    path.unlink()
    clock[0] = 0.0
    with pytest.raises(RunFileError, match="not created within 2 s"):
        wait_for_run_file(path, 2.0, sleep=lambda s: clock.__setitem__(0, clock[0] + s), now=lambda: clock[0])
