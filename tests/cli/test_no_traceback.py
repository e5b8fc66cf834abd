"""Bad input gets one clear line and a non-zero exit, never a Python traceback (the installed CLI in a
subprocess); a real bug gets one line asking for a report, its traceback only with --debug."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ecds_lab import cli

pytestmark = pytest.mark.slow
SESSIONS = Path(__file__).parents[1] / "data" / "sessions"
SWEEP_RUN = SESSIONS / "sweep.h5"


def ecds_lab(*args: str, shell_tail: str = "") -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "ecds_lab.cli", *map(str, args)]
    if shell_tail:
        return subprocess.run(" ".join(f"'{c}'" for c in command) + shell_tail, shell=True, capture_output=True,
                              text=True, timeout=120, check=False)
    return subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)


def one_line(done: subprocess.CompletedProcess, code: int = 2) -> str:
    assert "Traceback" not in done.stderr + done.stdout, done.stderr
    assert done.returncode == code, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    return lines[0]


@pytest.fixture
def run_copy(tmp_path) -> Path:
    copy = tmp_path / "sweep.h5"
    copy.write_bytes(SWEEP_RUN.read_bytes())
    return copy


def test_a_missing_station_file(experiments_dir, tmp_path):
    line = one_line(ecds_lab("run", experiments_dir / "displacement_sweep.yaml", "--station", tmp_path / "none.yaml",
                             "-o", tmp_path / "x.h5"))
    assert line.startswith("ecds-lab run: ") and "none.yaml" in line


def test_an_unknown_driver_option(experiments_dir, tmp_path):
    station = tmp_path / "station.yaml"
    station.write_text("simulated: {}\nbridge:\n  driver: hm8118\n  options: {speed_of_light: 3}\n")
    line = one_line(ecds_lab("run", experiments_dir / "displacement_sweep.yaml", "--station", station,
                             "-o", tmp_path / "x.h5"))
    assert "station.yaml" in line and "has no option 'speed_of_light'" in line and "allowed: none" in line
    station.write_text("simulated: {}\nscanner:\n  driver: daq970a\n  options: {chanels: {coil: 101}}\n")
    line = one_line(ecds_lab("run", experiments_dir / "displacement_sweep.yaml", "--station", station, "--dry-run"))
    assert "has no option 'chanels'; allowed: channels, thermocouple_type" in line


def test_an_excel_csv_with_a_byte_order_mark_is_read(run_copy, tmp_path):
    csv = tmp_path / "plain.csv"
    assert ecds_lab("export", run_copy, "-o", csv).returncode == 0
    excel = tmp_path / "excel.csv"
    excel.write_bytes(b"\xef\xbb\xbf" + csv.read_bytes().replace(b"\n", b"\r\n"))
    done = ecds_lab("fit", excel, "--json")
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr


def test_diagnose_on_one_row(tmp_path):
    csv = tmp_path / "one.csv"
    csv.write_text("time_s,x_mm,freq_hz,t_coil_c,t_target_c,ls_h,rs_ohm\n0,20,500,25,25,1e-4,1\n")
    line = one_line(ecds_lab("diagnose", csv))
    assert "one.csv: 1 reading(s)" in line and "at least 2" in line


def test_output_into_a_missing_folder_and_onto_the_input(run_copy, tmp_path):
    assert "does not exist" in one_line(ecds_lab("export", run_copy, "-o", tmp_path / "no" / "x.csv"))
    assert "is an input" in one_line(ecds_lab("export", run_copy, "-o", run_copy))
    assert "does not exist" in one_line(ecds_lab("report", run_copy, "-o", tmp_path / "no" / "r.html"))
    done = ecds_lab("run", Path(__file__).parents[2] / "experiments" / "displacement_sweep.yaml",
                    "-o", tmp_path / "no" / "deeper" / "x.h5", "-q")
    assert done.returncode == 0, done.stderr  # a run creates its folder


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
def test_output_into_a_read_only_folder(run_copy, tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    assert "not writable" in one_line(ecds_lab("export", run_copy, "-o", locked / "x.csv"))


def test_piping_into_head(run_copy):
    done = ecds_lab("diagnose", run_copy, "--json", shell_tail=" | head -c 20")
    assert "Traceback" not in done.stderr and "BrokenPipe" not in done.stderr, done.stderr
    done = ecds_lab("replay", run_copy, shell_tail=" | head -n 1")
    assert "Traceback" not in done.stderr, done.stderr


def test_an_unexpected_error_is_one_line_asking_for_a_report(capsys, monkeypatch):
    def broken(args: argparse.Namespace) -> int:
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(cli, "_cmd_export", broken)
    monkeypatch.delenv("ECDS_LAB_DEBUG", raising=False)
    assert cli.main(["export", "x.h5"]) == 70
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "ZeroDivisionError: float division by zero" in err and "please report" in err
    assert cli.main(["--debug", "export", "x.h5"]) == 70
    assert "Traceback" in capsys.readouterr().err
