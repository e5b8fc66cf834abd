"""Replies are checked against their format before they become data: cut short, run together or
shifted by an unsolicited line, a reply is re-queried once, then refused naming instrument, command, reply."""

from __future__ import annotations

import pytest

from ecds_lab.drivers.daq970a import DAQ970A
from ecds_lab.drivers.daq970a import SERIAL_SETTINGS as DAQ_SETTINGS
from ecds_lab.drivers.hm8118 import HM8118, XALL_REPLY
from ecds_lab.drivers.hm8118 import SERIAL_SETTINGS as BRIDGE_SETTINGS
from ecds_lab.drivers.hmp import HMP4040
from ecds_lab.drivers.hmp import SERIAL_SETTINGS as HMP_SETTINGS
from ecds_lab.drivers.replies import NR3, Field, ReplyFormat
from ecds_lab.errors import InstrumentError, ReplyFormatError
from ecds_lab.instruments import BridgeSettings


@pytest.fixture
def bridge(sim):
    bridge = HM8118(sim.serial("hm8118", BRIDGE_SETTINGS))
    bridge.configure(BridgeSettings())
    bridge.set_frequency(15000)
    return bridge


@pytest.fixture
def scanner(sim):
    scanner = DAQ970A(sim.serial("daq970a", DAQ_SETTINGS))
    scanner.configure()
    return scanner


@pytest.mark.parametrize("reply", [
    "1.23456E-04,5.83000E+0",        # the XALL? cut to 22 characters: Rs would read 5.83 instead of 58.3
    "1.23456E-04,5.83000E+01",       # the bin number lost
    "1.23456E-04,",                  # cut in half
    "1.23456E-04,5.83000E+01,0,7",   # two replies run together
    "OK",                            # an unsolicited line
    "1.23456E-04,5.8300xE+01,0",     # garbled
    "1.23456E+34,5.83000E+01,0",     # no bridge reading is that large
])
def test_a_bad_xall_reply_is_refused_with_the_reason(reply):
    with pytest.raises(ValueError):
        XALL_REPLY.parse(reply)


def test_a_good_xall_reply_is_read():
    assert XALL_REPLY.parse("1.23456E-04,-5.83000E+01,0") == [1.23456e-4, -58.3, 0]


def test_spaces_around_the_fields_are_read_as_without():
    assert XALL_REPLY.parse(" 1.23456E-04, -5.83000E+01 ,0 ") == [1.23456e-4, -58.3, 0]


def test_a_well_formed_value_out_of_its_range_is_named():
    with pytest.raises(ValueError, match=r"bin 100 is outside the plausible 0\.\.99"):
        XALL_REPLY.parse("1.23456E-04,-5.83000E+01,100")


def test_a_counted_reply_takes_exactly_that_many_fields():
    scan = ReplyFormat((Field("reading", NR3),), count=1)
    assert scan.parse("+2.1E+01,+2.2E+01", count=2) == [21.0, 22.0]
    with pytest.raises(ValueError, match="2 field"):
        scan.parse("+2.1E+01,+2.2E+01", count=3)


def test_a_field_syntax_with_a_capturing_group_is_refused():
    with pytest.raises(ValueError, match=r"\(\?:\.\.\.\)"):
        Field("main", r"(\d+)")


def test_a_reply_cut_short_once_is_re_queried(sim, bridge):
    good = bridge.measure()
    sim.lab.faults.short_replies["hm8118:XALL?"] = 1
    before = len(bridge.transport.transcript.sent())
    reading = bridge.measure()
    assert bridge.transport.transcript.sent()[before:] == ["*TRG", "*WAI", "XALL?", "XALL?"]
    assert reading.secondary == pytest.approx(good.secondary, rel=1e-3)


def test_a_reply_always_cut_short_fails_naming_instrument_command_and_reply(sim, bridge):
    sim.lab.faults.short_replies["hm8118:XALL?"] = -1
    with pytest.raises(ReplyFormatError) as caught:
        bridge.measure()
    message = str(caught.value)
    assert message.startswith("hm8118: command 'XALL?' failed with reply ")
    assert "field(s), expected 3" in message and "the first reply" in message
    assert isinstance(caught.value, InstrumentError)


def test_an_unsolicited_line_is_drained_and_later_replies_stay_in_step(sim, bridge):
    good = bridge.measure()
    sim.lab.faults.unsolicited_lines["hm8118"] = ["OVERLOAD"]
    first = bridge.measure()
    second = bridge.measure()
    for reading in (first, second):
        assert reading.main == pytest.approx(good.main, rel=1e-3)
    assert bridge.frequency_hz == 15000  # the next query gets its own reply, not a stale one


def test_a_scanner_reply_cut_short_is_re_queried_then_refused(sim, scanner):
    assert set(scanner.read_temperatures_c()) == {"coil", "target", "ambient"}
    sim.lab.faults.short_replies["daq970a:READ?"] = 1
    assert scanner.read_temperatures_c()["ambient"] > 15  # the re-query's full scan, never a cut "+2"
    sim.lab.faults.short_replies["daq970a:READ?"] = -1
    with pytest.raises(ReplyFormatError, match=r"daq970a: command 'READ\?' failed with reply .*expected 3"):
        scanner.read_temperatures_c()


def test_the_supply_read_back_is_checked(sim):
    supply = HMP4040(sim.serial("hmp4040", HMP_SETTINGS))
    assert supply.read_back(1) == (0.0, 0.0)
    sim.lab.faults.short_replies["hmp4040:MEAS:CURR?"] = -1
    with pytest.raises(InstrumentError, match="MEAS:CURR"):
        supply.read_back(1)
