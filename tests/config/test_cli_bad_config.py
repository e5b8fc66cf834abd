"""The installed command on each bad file of issue 13, in a subprocess: exit code 2, one line on stderr
naming the file, no traceback, and no hang (a bounded timeout)."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow


def test_one_line_and_no_traceback(bad_input):
    argv = [sys.executable, "-m", "ecds_lab.cli", "run", str(bad_input.experiment), "--dry-run"]
    if bad_input.station is not None:
        argv += ["--station", str(bad_input.station)]
    done = subprocess.run(argv, capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr and "Traceback" not in done.stdout
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f"ecds-lab run: {bad_input.bad_file}:")
    for expected in bad_input.expected:
        assert expected in lines[0]
    assert done.stdout == ""
