"""Fixtures of the replay tests: the recorded sessions, copies of them edited, and fresh simulated runs."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import h5py
import pytest

ROOT = Path(__file__).resolve().parents[2]
SESSIONS = ROOT / "tests" / "data" / "sessions"
#: Seconds since boot, roughly, as time.monotonic() gives them in a real lab.
MONOTONIC_ORIGIN_S = 1_734_567.891


@pytest.fixture
def session_copy(tmp_path: Path) -> Callable[..., Path]:
    """``session_copy("sweep", edit)``: a copy of a recorded session in tmp_path, edited in place by
    ``edit(h5file)``."""

    def copy(name: str, edit: Callable[[h5py.File], None] | None = None, *, suffix: str = "") -> Path:
        path = tmp_path / f"{name}{suffix}.h5"
        shutil.copyfile(SESSIONS / f"{name}.h5", path)
        if edit is not None:
            with h5py.File(path, "a") as f:
                edit(f)
        return path

    return copy


def _as_real_lab_recording(f: h5py.File) -> None:
    transcripts = f["entry/transcripts"]
    if "log" in transcripts:  # the transcript log
        log = transcripts["log"][()]
        log["clock_s"] += MONOTONIC_ORIGIN_S
        transcripts["log"][...] = log
    else:  # files written before it: one group per role
        for group in transcripts.values():
            events = group["events"][()]
            events[:, 0] += MONOTONIC_ORIGIN_S
            group["events"][...] = events
    f["entry"].attrs["station_yaml"] = (ROOT / "experiments" / "stations" / "real_lab_template.yaml").read_text()


@pytest.fixture
def as_real_lab_recording() -> Callable[[h5py.File], None]:
    """An edit for ``session_copy`` that makes a simulated recording look like one from the real lab:
    wall-clock (monotonic, ~1.7e6 s) transcript times and the real lab's station file (serial ports
    and VISA resources instead of simulators)."""
    return _as_real_lab_recording


@pytest.fixture(scope="session")
def fresh_sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run made now on the simulated lab (the short sweep of the recorded sessions), not compacted."""
    from ecds_lab.runner.session import run_experiment

    output = tmp_path_factory.mktemp("fresh") / "sweep.h5"
    result = run_experiment(SESSIONS / "sweep.yaml", None, output, progress=False)
    assert result.status == "completed"
    return output
