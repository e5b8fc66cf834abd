"""A line already waiting on the link when a query goes out is never that query's reply (issue 24, point 9):
it is discarded, recorded in the transcript as kind 'stale' and summed up for the run's notes; a replay of
the recording discards it at the same place."""

from __future__ import annotations

import pytest

from ecds_lab.clock import SimulatedClock
from ecds_lab.drivers.hm8118 import HM8118
from ecds_lab.drivers.hm8118 import SERIAL_SETTINGS as BRIDGE_SETTINGS
from ecds_lab.drivers.hmp import HMP4040
from ecds_lab.drivers.hmp import VISA_SETTINGS as HMP_VISA
from ecds_lab.errors import ReplayDivergence
from ecds_lab.instruments import BridgeSettings
from ecds_lab.transports.replay import ReplayTransport
from ecds_lab.transports.transcript import RECEIVED, SENT, STALE
from ecds_lab.transports.visa_link import VisaTransport

#: A well-formed, plausible XALL? reply (1 mH, 10 ohm): checking the reply's format cannot tell it from a reading.
STALE_READING = "1.00000E-03,1.00000E+01,0"


@pytest.fixture
def bridge(sim):
    bridge = HM8118(sim.serial("hm8118", BRIDGE_SETTINGS))
    bridge.configure(BridgeSettings())
    bridge.set_frequency(15000)
    return bridge


def test_a_reading_shaped_line_waiting_before_xall_is_discarded_not_taken_as_the_reading(sim, bridge):
    good = bridge.measure()
    sim.lab.faults.stale_lines["hm8118:*TRG"] = [STALE_READING]  # sent the moment *TRG arrives, before XALL?
    reading = bridge.measure()
    assert reading.main == pytest.approx(good.main, rel=1e-3)
    assert reading.main != pytest.approx(1e-3)
    events = bridge.transport.transcript.events
    stale = [e for e in events if e.kind == STALE]
    assert [e.text for e in stale] == [STALE_READING]
    after = events[events.index(stale[0]) + 1:]
    assert (after[0].kind, after[0].text) == (SENT, "XALL?")  # discarded before the query went out
    assert after[1].kind == RECEIVED and after[1].text != STALE_READING
    note = bridge.transport.stale_note()
    assert note is not None and note.startswith("hm8118: 1 stale line(s)")
    assert repr(STALE_READING) in note and "'XALL?'" in note
    assert bridge.measure().main == pytest.approx(good.main, rel=1e-3)  # later replies stay in step
    assert bridge.transport.stale_count == 1


def test_a_clean_link_discards_nothing(bridge):
    bridge.measure()
    bridge.measure()
    assert bridge.transport.stale_note() is None
    assert not [e for e in bridge.transport.transcript.events if e.kind == STALE]


def test_a_visa_serial_resource_discards_a_waiting_line_too(sim):
    supply = HMP4040(VisaTransport("hmp4040", f"ASRL{sim.url('hmp4040')}::INSTR", clock=sim.clock, **HMP_VISA))
    try:
        identity = supply.identity()
        supply.set_output(3, 5.0, 0.5)  # output 3 has no heater: nothing warms
        supply.enable(3, True)
        sim.lab.faults.stale_lines["hmp4040:INST OUT3"] = ["ROHDE&SCHWARZ,HMP4040,0,0"]
        assert supply.read_back(3)[0] == pytest.approx(5.0)
        assert supply.identity() == identity
        stale = [e.text for e in supply.transport.transcript.events if e.kind == STALE]
        assert stale == ["ROHDE&SCHWARZ,HMP4040,0,0"]
    finally:
        supply.close()


def test_a_replay_discards_the_recorded_stale_line_at_the_same_place(sim, bridge):
    sim.lab.faults.stale_lines["hm8118:*TRG"] = [STALE_READING]
    measured = [bridge.measure().main for _ in range(2)]
    events = list(bridge.transport.transcript.events)
    replayed = HM8118(ReplayTransport("hm8118", events, clock=SimulatedClock(), **BRIDGE_SETTINGS))
    replayed._frequency_hz = 15000.0  # the recording starts after set_frequency
    replayed.transport.position = next(i for i, e in enumerate(events) if e.kind == SENT and e.text == "*TRG")
    assert [replayed.measure().main for _ in range(2)] == measured
    assert replayed.transport.finished and replayed.transport.stale_count == 1


def test_a_replay_that_skips_a_recorded_stale_line_diverges_naming_it(sim, bridge):
    sim.lab.faults.stale_lines["hm8118:*TRG"] = [STALE_READING]
    bridge.measure()
    events = list(bridge.transport.transcript.events)
    start = next(i for i, e in enumerate(events) if e.kind == SENT and e.text == "*TRG")
    link = ReplayTransport("hm8118", events, clock=SimulatedClock(), **BRIDGE_SETTINGS)
    link.position = start
    link.write("*TRG")
    link.write("*WAI")
    with pytest.raises(ReplayDivergence, match="stale line"):
        link.read_line()  # the recording has the stale line discarded before a query here, not a read


def test_the_bridges_error_for_a_refused_setting_is_that_settings_answer_not_a_stale_line(sim, bridge):
    """The HM8118 answers ERROR to a set command it refuses [M23]; waiting when the read-back goes out, it is
    the set's answer (its write_replies), so the read-back reads it. The read-back's own reply, left unread,
    is a line from an earlier exchange when the next query goes out: discarded, so the link stays in step."""
    bridge.transport.write("FREQ 21")  # not one of the 69 frequencies
    assert bridge.transport.query("FREQ?") == "ERROR"
    assert bridge.transport.stale_note() is None
    bridge.transport.write("VOLT 0.5")
    assert bridge.transport.query("VOLT?") == "0.500"  # not the first read-back's '15000'
    assert [e.text for e in bridge.transport.transcript.events if e.kind == STALE] == ["15000"]
