"""Issue 13: every bad input listed there is refused before anything moves, with one message naming the
file, the field and what is allowed (the inputs themselves are in conftest.py)."""

from __future__ import annotations

import pytest

from ecds_lab.cli import main
from ecds_lab.errors import ConfigError
from ecds_lab.runner.session import run_experiment


def test_run_refuses_before_touching_an_instrument(bad_input, tmp_path, instrument_guard):
    output = tmp_path / "run.h5"
    with pytest.raises(ConfigError) as refused:
        run_experiment(bad_input.experiment, bad_input.station, output, progress=False)
    message = str(refused.value)
    assert message.startswith(f"{bad_input.bad_file}:")
    assert len(message.splitlines()) == 1, message
    for expected in bad_input.expected:
        assert expected in message
    assert instrument_guard.untouched and not output.exists()


def test_dry_run_exits_2_naming_the_file(bad_input, instrument_guard, capsys):
    argv = ["run", str(bad_input.experiment), "--dry-run"]
    if bad_input.station is not None:
        argv += ["--station", str(bad_input.station)]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith(f"ecds-lab run: {bad_input.bad_file}:")
    for expected in bad_input.expected:
        assert expected in captured.err
    assert instrument_guard.untouched
