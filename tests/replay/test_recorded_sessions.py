"""The recorded sessions in tests/data/sessions replay through today's drivers and runner.

Every ``*.h5`` in the folder is replayed, so a recording from the real lab dropped there is
tested the same way as the three that record_sessions.py makes on the simulated lab.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ecds_lab.cli import main
from ecds_lab.data.columns import INDEX, LOGGED_POINT
from ecds_lab.errors import ReplayDivergence
from ecds_lab.instruments import BridgeSettings
from ecds_lab.replay import replay_run
from ecds_lab.storage.reader import read_run

ROOT = Path(__file__).resolve().parents[2]
SESSIONS = ROOT / "tests" / "data" / "sessions"
RECORDINGS = sorted(SESSIONS.glob("*.h5"))
MADE_BY_THE_GENERATOR = ("sweep", "instrument_error", "heating")


def test_the_generated_sessions_are_there_and_small():
    names = {path.stem for path in RECORDINGS}
    assert set(MADE_BY_THE_GENERATOR) <= names, f"run {SESSIONS / 'record_sessions.py'}"
    for name in MADE_BY_THE_GENERATOR:
        assert (SESSIONS / f"{name}.h5").stat().st_size < 300_000


@pytest.mark.parametrize("path", RECORDINGS, ids=lambda p: p.stem)
def test_every_recorded_session_replays_and_reproduces(path):
    recorded = read_run(path)
    result = replay_run(path)
    assert result.reproduced, result.differences
    assert result.differences == []
    assert result.replay_status == result.original_status == recorded.status
    assert result.replayed_points == result.original_points == len(recorded.points)


@pytest.mark.parametrize("path", RECORDINGS, ids=lambda p: p.stem)
def test_ecds_lab_replay_says_reproduced(path, capsys):
    assert main(["replay", str(path)]) == 0
    out = capsys.readouterr().out
    assert "reproduced: every row equal" in out and "NOT" not in out


def test_the_instrument_error_session_fails_again_the_same_way():
    recorded = read_run(SESSIONS / "instrument_error.h5")
    assert recorded.status == "failed"
    assert recorded.metadata["error"] == "InstrumentError: bridge: command 'FREQ 15000' failed with reply 'ERROR'"
    assert len(recorded.points) == 2  # the two 500 Hz readings at the first position
    result = replay_run(SESSIONS / "instrument_error.h5")
    assert result.reproduced
    assert (result.replay_status, result.replayed_points) == ("failed", 2)
    assert result.error == recorded.metadata["error"]


def test_the_heating_session_heated_logged_and_completed():
    recorded = read_run(SESSIONS / "heating.h5")
    assert recorded.status == "completed"
    points = recorded.points
    assert (points[:, INDEX["kind"]] == LOGGED_POINT).any()  # readings logged during the ramps
    assert np.nanmax(points[:, INDEX["target_heater_w"]]) > 0
    assert np.nanmax(points[:, INDEX["t_target_c"]]) > 29.0
    assert replay_run(SESSIONS / "heating.h5").reproduced


@pytest.mark.parametrize("name", MADE_BY_THE_GENERATOR)
def test_a_real_lab_recording_with_wall_clock_times_replays_the_same_way(name, session_copy, as_real_lab_recording,
                                                                        capsys):
    path = session_copy(name, as_real_lab_recording, suffix="-real-lab")
    recorded = read_run(path)
    assert min(events[0].clock_s for events in recorded.transcripts.values()) > 1e6
    assert "/dev/ttyUSB0" in recorded.metadata["station_yaml"]
    result = replay_run(path)
    assert result.reproduced, result.differences
    assert result.replay_status == recorded.status
    assert main(["replay", str(path)]) == 0
    assert "reproduced" in capsys.readouterr().out


# -- the pytest fixture, as the README shows it ----------------------------------------------
def test_recorded_station_as_in_the_readme(recorded_station, monkeypatch):
    monkeypatch.chdir(ROOT)
    station = recorded_station("tests/data/sessions/sweep.h5")
    identities = station.identify()  # must send what the recording holds, in order
    assert identities == read_run(SESSIONS / "sweep.h5").identities
    station.bridge.configure(BridgeSettings(function="L-R", circuit="series", voltage_v=1.5, speed="slow",
                                            averages=1))
    station.bridge.set_frequency(500)
    reading = station.bridge.measure()  # the recorded reply, parsed by today's driver
    first = read_run(SESSIONS / "sweep.h5").points[0]
    assert (reading.main, reading.secondary) == (first[INDEX["ls_h"]], first[INDEX["rs_ohm"]])


def test_recorded_station_raises_replay_divergence_for_a_different_command(recorded_station):
    station = recorded_station(SESSIONS / "sweep.h5")
    station.identify()
    with pytest.raises(ReplayDivergence, match=r"^bridge: replay diverges at transcript event \d+ of \d+: "
                                               r"expected command 'PMOD 2', got command 'FREQ 1000'$"):
        station.bridge.set_frequency(1000)  # the recording configures the bridge first
