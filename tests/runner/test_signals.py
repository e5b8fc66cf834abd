"""SIGTERM and SIGHUP take Ctrl-C's path: heater off and verified off, status aborted naming the signal,
exit code 128 + signal; a supply that stops answering or stays on ends the run failed, loudly."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from ecds_lab.drivers.hmp import HMP4040
from ecds_lab.runner.session import run_experiment
from ecds_lab.simulators.hmp import HMPEmulator
from ecds_lab.storage.reader import read_run
from ecds_lab.transports.transcript import RECEIVED, SENT

HEATING = "target_heating_copper.yaml"
#: Past the first (ambient) sweep, while heating to the second setpoint (as in test_safe_state.py).
MID_HEATING_S = 1800.0
CHILD = Path(__file__).with_name("heating_child.py")


def run_heating(*args, **kwargs):
    return run_experiment(*args, progress=False, **kwargs)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_a_signal_while_heating_aborts_with_the_heater_off(
        signum, tmp_path, experiments_dir, opened_stations, at_simulated_time, assert_heater_off):
    on_at_signal: list[bool] = []

    def kill() -> None:
        on_at_signal.append(any(out.on for out in opened_stations[0].lab.supply.values()))
        os.kill(os.getpid(), signum)

    at_simulated_time(MID_HEATING_S, kill)
    output = tmp_path / "heating.h5"
    result = run_heating(experiments_dir / HEATING, None, output)

    assert on_at_signal == [True]
    assert result.status == "aborted" and result.stopped_by == signum
    assert result.error == f"stopped by {signal.Signals(signum).name}"
    recorded = read_run(output)
    assert recorded.status == "aborted" and recorded.metadata["error"] == result.error
    assert_heater_off(opened_stations[0], output)
    assert signal.getsignal(signum) is signal.SIG_DFL  # the handler is removed after the run


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_signal_from_outside_stops_the_process_safely_with_128_plus_signal(signum, tmp_path, experiments_dir):
    output, marker = tmp_path / "heating.h5", tmp_path / "heating.marker"
    child = subprocess.Popen([sys.executable, str(CHILD), str(experiments_dir / HEATING), str(output), str(marker)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not marker.exists() and child.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert marker.exists() and marker.read_text() == "heater on", child.communicate()
        time.sleep(0.2)
        child.send_signal(signum)
        out, err = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 128 + signum, err
    assert "Traceback" not in err
    supply = json.loads(out.strip().splitlines()[-1])
    assert supply == {"1": False, "2": False, "3": False, "4": False}
    recorded = read_run(output)
    assert recorded.status == "aborted"
    assert ("Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name) in recorded.metadata["error"]
    heater = recorded.transcripts["heater"]
    sent = [e.text for e in heater if e.kind == SENT]
    assert "OUTP:GEN OFF" in sent and sent[-3:] == ["INST OUT2", "OUTP?", "MEAS:CURR?"]
    replies = [e.text for e in heater if e.kind == RECEIVED]
    assert replies[-1] == "0.0000" and replies[-2] == "0"  # output 2 reads off and draws no current


def test_a_supply_that_stops_answering_while_heating_fails_the_run_naming_the_outputs(
        tmp_path, experiments_dir, opened_stations, at_simulated_time):
    at_simulated_time(MID_HEATING_S, lambda: opened_stations[0].lab.faults.silent_instruments.add("hmp4040"))
    output = tmp_path / "silent.h5"
    result = run_heating(experiments_dir / HEATING, None, output)

    assert result.status == "failed"
    assert "SWITCH OFF HEATER SUPPLY OUTPUT(S) 1, 2 BY HAND" in result.error
    assert "TransportTimeout" in result.error
    recorded = read_run(output)
    assert recorded.status == "failed" and recorded.metadata["error"] == result.error
    assert any(out.on for out in opened_stations[0].lab.supply.values())  # the simulated heater really is on


def test_a_supply_whose_output_stays_on_fails_the_run(tmp_path, experiments_dir, opened_stations, at_simulated_time,
                                                      monkeypatch):
    real_all_off = HMP4040.all_off

    def all_off_on_a_stuck_supply(self: HMP4040) -> None:
        """From here on the simulated supply ignores its switches (a relay welded shut)."""
        monkeypatch.setattr(HMPEmulator, "set_master", lambda emulator, argument: None)
        monkeypatch.setattr(HMPEmulator, "set_armed", lambda emulator, argument: None)
        real_all_off(self)

    at_simulated_time(MID_HEATING_S, KeyboardInterrupt)
    monkeypatch.setattr(HMP4040, "all_off", all_off_on_a_stuck_supply)
    output = tmp_path / "stuck.h5"
    result = run_heating(experiments_dir / HEATING, None, output)

    assert result.status == "failed"
    assert "master switch (OUTP:GEN?) still reads on" in result.error
    assert "output 1 reads ON" in result.error and "SWITCH OFF HEATER SUPPLY OUTPUT(S) 1, 2 BY HAND" in result.error
    assert "Ctrl-C" in result.error  # what happened before is kept
    assert read_run(output).metadata["error"] == result.error
