"""ReplayTransport: serves a recorded transcript back to driver code and stops at the first divergence."""

from __future__ import annotations

import pytest

from ecds_lab.clock import SimulatedClock
from ecds_lab.drivers.hm8118 import HM8118, SERIAL_SETTINGS
from ecds_lab.errors import ReplayDivergence, TransportError, TransportTimeout
from ecds_lab.instruments import BridgeSettings
from ecds_lab.transports.replay import ReplayState, ReplayTransport
from ecds_lab.transports.transcript import ERROR, RECEIVED, SENT, TranscriptEvent

WALL = 1.7e9  # wall_s of the recorded events; replay never looks at it


def events(*items: tuple[float, str, str]) -> list[TranscriptEvent]:
    return [TranscriptEvent(clock_s, WALL + clock_s, kind, text) for clock_s, kind, text in items]


BRIDGE_TRAFFIC = events(
    (0.0, SENT, "*IDN?"), (0.1, RECEIVED, "HAMEG Instruments, HM8118,013206727,1.57"),
    (0.3, SENT, "FREQ 500"), (0.5, SENT, "FREQ?"), (0.6, RECEIVED, "500"),
)


def replay(items: list[TranscriptEvent], name: str = "bridge", **options) -> ReplayTransport:
    return ReplayTransport(name, items, clock=options.pop("clock", SimulatedClock()), **options)


# -- matching ------------------------------------------------------------------------------
def test_the_recorded_conversation_replays_exactly():
    link = replay(BRIDGE_TRAFFIC)
    assert link.query("*IDN?") == "HAMEG Instruments, HM8118,013206727,1.57"
    link.write("FREQ 500")
    assert link.query("FREQ?") == "500"
    assert link.finished
    # the replay link keeps its own transcript, the same conversation again
    assert [(e.kind, e.text) for e in link.transcript] == [(e.kind, e.text) for e in BRIDGE_TRAFFIC]


def test_terminations_do_not_matter_only_the_command_text_does():
    link = replay(BRIDGE_TRAFFIC, write_termination="\r", read_termination="\r")
    assert link.query("*IDN?").startswith("HAMEG")
    link.write("FREQ 500")


def test_raw_real_time_bytes_match_as_recorded():
    """GRBL's real-time '?' and raw bytes that happen to end like a termination are compared as sent."""
    link = replay(events((0.0, SENT, "?"), (0.01, RECEIVED, "<Idle|MPos:0.000,0.000,0.000|FS:0,0>"),
                         (0.02, SENT, "$X\n")), name="slide")
    link.write_bytes(b"?")
    assert link.read_line().startswith("<Idle")
    link.write_bytes(b"$X\n")
    assert link.finished


# -- divergence -------------------------------------------------------------------------------
def test_a_different_command_raises_a_divergence_naming_instrument_position_expected_and_actual():
    link = replay(BRIDGE_TRAFFIC)
    link.query("*IDN?")
    with pytest.raises(ReplayDivergence) as caught:
        link.write("FREQ 1000")
    message = str(caught.value)
    assert not isinstance(caught.value, TransportError)  # not disguised as a broken link
    assert message == ("bridge: replay diverges at transcript event 3 of 5: "
                       "expected command 'FREQ 500', got command 'FREQ 1000'")


def test_reading_where_a_command_was_recorded_diverges():
    link = replay(BRIDGE_TRAFFIC)
    link.query("*IDN?")
    with pytest.raises(ReplayDivergence, match=r"event 3 of 5: expected command 'FREQ 500' to be sent next, "
                                               r"got a read"):
        link.read_line()


def test_sending_where_a_reply_was_recorded_diverges():
    link = replay(BRIDGE_TRAFFIC)
    link.write("*IDN?")
    with pytest.raises(ReplayDivergence, match=r"event 2 of 5: expected a read \(recorded reply 'HAMEG.*'\), "
                                               r"got command 'FREQ 500'"):
        link.write("FREQ 500")


def test_the_first_divergence_stops_every_link_of_the_station():
    state = ReplayState()
    bridge = replay(BRIDGE_TRAFFIC, state=state)
    heater = replay(events((0.0, SENT, "OUTP:GEN OFF")), name="heater", state=state)
    with pytest.raises(ReplayDivergence) as first:
        bridge.write("*RST")
    assert state.divergence is first.value
    for action in (lambda: heater.write("OUTP:GEN OFF"), lambda: bridge.read_line()):
        with pytest.raises(ReplayDivergence) as later:
            action()
        assert str(later.value) == str(first.value)  # the report stays the first divergence
    assert heater.position == 0


# -- recorded failures ---------------------------------------------------------------------------
def test_a_recorded_timeout_is_reproduced_as_transport_timeout_at_the_recorded_time():
    clock = SimulatedClock()
    link = replay(events((1.0, SENT, "READ?"), (6.0, ERROR, "timeout"), (6.1, SENT, "SYST:ERR?"),
                         (6.2, RECEIVED, '-221,"Settings conflict"')), name="scanner", clock=clock, timeout_s=5.0)
    with pytest.raises(TransportTimeout, match="scanner: no reply within 5 s"):
        link.query("READ?")
    assert clock.now() == 6.0
    assert link.query("SYST:ERR?") == '-221,"Settings conflict"'
    assert link.finished


def test_a_recorded_send_failure_is_reproduced():
    link = replay(events((0.0, SENT, "*IDN?"), (0.0, ERROR, "device reports readiness to read but returned no data")))
    with pytest.raises(TransportError, match=r"bridge: sending '\*IDN\?' failed: device reports .* \(recorded\)"):
        link.write("*IDN?")
    assert link.finished


# -- end of the recording ------------------------------------------------------------------------
def test_traffic_past_the_end_of_the_recording_diverges():
    link = replay(BRIDGE_TRAFFIC[:2])
    link.query("*IDN?")
    assert link.finished
    with pytest.raises(ReplayDivergence, match=r"bridge: replay diverges after the last of 2 transcript events: "
                                               r"expected the end of the recording, got command 'FREQ 500'"):
        link.write("FREQ 500")


def test_a_read_past_the_end_of_the_recording_diverges():
    link = replay(BRIDGE_TRAFFIC[:1])
    link.write("*IDN?")
    with pytest.raises(ReplayDivergence, match="expected the end of the recording, got a read"):
        link.read_line()


def test_remaining_says_where_an_unfinished_replay_stopped():
    link = replay(BRIDGE_TRAFFIC)
    link.query("*IDN?")
    assert not link.finished
    assert link.remaining() == ("bridge: replay ended at transcript event 3 of 5; "
                                "the recording continues with command 'FREQ 500'")


# -- time ---------------------------------------------------------------------------------------
def test_the_clock_follows_the_recorded_times():
    clock = SimulatedClock()
    link = replay(BRIDGE_TRAFFIC, clock=clock)
    seen = []
    link.write("*IDN?")
    seen.append(clock.now())
    link.read_line()
    seen.append(clock.now())
    link.write("FREQ 500")
    seen.append(clock.now())
    link.query("FREQ?")
    seen.append(clock.now())
    assert seen == [0.0, 0.1, 0.3, 0.6]


def test_a_wall_clock_recording_is_replayed_relative_to_its_origin():
    """A real lab records monotonic seconds (e.g. 1.7e6 s since boot): replay time starts at the origin."""
    origin = 1_734_567.891
    shifted = [e._replace(clock_s=e.clock_s + origin) for e in BRIDGE_TRAFFIC]
    clock = SimulatedClock()
    link = replay(shifted, clock=clock, clock_origin_s=origin)
    link.query("*IDN?")
    assert clock.now() == pytest.approx(0.1, abs=1e-6)
    link.write("FREQ 500")
    link.query("FREQ?")
    assert clock.now() == pytest.approx(0.6, abs=1e-6)


def test_the_clock_never_runs_backwards():
    """Code that waited longer than the recording did keeps its own, later, time."""
    clock = SimulatedClock()
    link = replay(BRIDGE_TRAFFIC, clock=clock)
    link.query("*IDN?")
    clock.sleep(5.0)
    link.write("FREQ 500")
    assert clock.now() == 5.1


# -- through a driver: record from the simulated bridge, replay to the same driver ---------------
def _session(bridge: HM8118) -> list:
    identity = bridge.identity()
    bridge.configure(BridgeSettings(function="L-R", circuit="series", voltage_v=1.5, speed="slow", averages=1))
    readings = []
    for frequency in (500, 15000):
        bridge.set_frequency(frequency)
        readings.append(bridge.measure())
    return [identity, *readings]


def test_a_driver_session_recorded_from_the_simulator_replays_to_the_same_results(sim):
    recorded_link = sim.serial("hm8118", SERIAL_SETTINGS)
    recorded = _session(HM8118(recorded_link))
    recording = list(recorded_link.transcript)
    recorded_link.close()

    clock = SimulatedClock()
    link = ReplayTransport("bridge", recording, clock=clock, **SERIAL_SETTINGS)
    assert _session(HM8118(link)) == recorded
    assert link.finished
    assert clock.now() == recording[-1].clock_s  # the measurements took their recorded time


def test_a_changed_driver_is_caught_at_its_first_different_command(sim, monkeypatch):
    recorded_link = sim.serial("hm8118", SERIAL_SETTINGS)
    _session(HM8118(recorded_link))
    recording = list(recorded_link.transcript)
    recorded_link.close()

    monkeypatch.setattr(HM8118.frequency_hz, "set_command", "FREQ {:.1f}")
    link = ReplayTransport("bridge", recording, clock=SimulatedClock(), **SERIAL_SETTINGS)
    position = [e.text for e in recording].index("FREQ 500") + 1
    with pytest.raises(ReplayDivergence, match=rf"^bridge: replay diverges at transcript event {position} of "
                                               rf"{len(recording)}: expected command 'FREQ 500', "
                                               rf"got command 'FREQ 500.0'$"):
        _session(HM8118(link))
