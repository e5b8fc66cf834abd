"""The SCPI emulator base, exercised over a real serial link: headers, compound lines, the error queue."""

from __future__ import annotations

import pytest

from ecds_lab.errors import TransportTimeout
from ecds_lab.simulators.scpi import header_pattern

LINK = {"write_termination": "\n", "read_termination": "\n", "timeout_s": 1.0}


@pytest.fixture
def link(sim):
    return sim.serial("hmp4040", LINK)


@pytest.mark.parametrize("header, matches", [
    ("VOLT?", True), ("volt?", True), ("VOLTAGE?", True), ("SOUR:VOLT?", True), (":VOLT:LEV?", True),
    ("source:voltage:level:immediate:amplitude?", True), ("VOLTA?", False), ("VOLT", False), ("LEV:VOLT?", False),
])
def test_short_and_long_forms_and_optional_nodes(header, matches):
    assert bool(header_pattern("[SOURce:]VOLTage[:LEVel][:IMMediate][:AMPLitude]?").fullmatch(header)) is matches


def test_compound_line_answers_in_one_line(link):
    link.write("INST OUT2;VOLT 3;CURR 0.5")
    assert link.query("VOLT?;CURR?") == "3.000;0.5000"
    assert link.query("INST:NSEL?;*IDN?").startswith("2;ROHDE&SCHWARZ")


def test_header_path_carries_over_after_a_semicolon(link):
    link.write("OUTP:SEL ON;GEN ON")  # = OUTP:SEL ON; OUTP:GEN ON
    assert link.query("OUTP:GEN?") == "1"
    link.write("OUTP:SEL OFF;VOLT 1")  # VOLT becomes OUTP:VOLT, which does not exist
    assert link.query("SYST:ERR?") == '-113,"Undefined header"'
    link.write("OUTP:SEL OFF;:VOLT 1")  # a leading colon starts again at the root
    assert link.query("SYST:ERR?") == '+0,"No error"'


def test_error_queue_is_fifo_with_standard_texts(link):
    for command in ("FOO", "VOLT 99", "OUTP MAYBE", "VOLT", "VOLT abc"):
        link.write(command)
    assert [link.query("SYST:ERR?") for _ in range(6)] == [
        '-113,"Undefined header"', '-222,"Data out of range"', '-224,"Illegal parameter value"',
        '-109,"Missing parameter"', '-104,"Data type error"', '+0,"No error"',
    ]


def test_rst_keeps_errors_cls_clears_them(link):
    link.write("FOO")
    link.write("*RST")
    assert link.query("SYST:ERR?") == '-113,"Undefined header"'
    link.write("FOO")
    link.write("*CLS")
    assert link.query("SYSTem:ERRor:NEXT?") == '+0,"No error"'
    assert link.query("*OPC?") == "1"


def test_queue_overflow_replaces_the_newest(sim):
    link = sim.serial("34970a", LINK)  # the 34970A keeps 10 errors
    for _ in range(12):
        link.write("FOO")
    errors = [link.query("SYST:ERR?") for _ in range(11)]
    assert errors[8] == '-113,"Undefined header"' and errors[9] == '-350,"Queue overflow"'
    assert errors[10] == '+0,"No error"'


def test_refused_query_sends_no_reply(link):
    with pytest.raises(TransportTimeout):
        link.query("NOPE?")
    assert link.query("SYST:ERR?") == '-113,"Undefined header"'


# -- IEEE 488.2 common commands and status model -------------------------------------------------------

def test_event_status_register_records_error_classes_and_clears_on_read(link):
    assert link.query("*ESR?") == "128"  # power on
    link.write("FOO")  # -113: command error, bit 5
    link.write("VOLT 99")  # -222: execution error, bit 4
    assert link.query("*ESR?") == str(32 + 16)
    assert link.query("*ESR?") == "0"
    link.write("*CLS")
    link.write("*IDN? 1")  # a parameter a common command does not take
    assert link.query("SYST:ERR?") == '-108,"Parameter not allowed"'


def test_status_byte_summarises_queue_and_enabled_events(link):
    link.write("*CLS")
    assert link.query("*STB?") == "0"
    link.write("FOO")
    assert link.query("*STB?") == "4"  # error queue not empty
    link.write("*ESE 32")
    assert link.query("*ESE?") == "32"
    assert link.query("*STB?") == str(4 + 32)  # ESB: an enabled ESR bit is set
    link.write("*SRE 32")
    assert link.query("*SRE?") == "32"
    assert link.query("*STB?") == str(4 + 32 + 64)  # MSS
    link.write("*CLS")  # clears queue and ESR, keeps the enable masks
    assert link.query("*STB?") == "0" and link.query("*ESE?") == "32"
    link.write("*ESE 256")
    assert link.query("SYST:ERR?") == '-222,"Data out of range"'


def test_opc_sets_its_bit_when_the_scan_is_done_and_tst_passes(sim):
    scanner = sim.serial("daq970a", LINK)
    scanner.write("CONF:TEMP TC,K,(@101:103)")
    scanner.write("*CLS")
    scanner.write("INIT;*OPC")
    assert scanner.query("*ESR?") == "+0"  # the scan is still running
    sim.clock.sleep(0.3)
    assert scanner.query("*ESR?") == "+1"
    assert scanner.query("*TST?") == "+0"


# -- DAQ970A / 34970A additions --------------------------------------------------------------------------

def test_init_then_fetch_returns_the_scan_which_stays_in_memory(sim):
    scanner = sim.serial("daq970a", LINK)
    with pytest.raises(TransportTimeout):
        scanner.query("FETC?")  # nothing in memory yet
    assert scanner.query("SYST:ERR?") == '-230,"Data corrupt or stale"'
    scanner.write("CONF:TEMP TC,K,(@101:102)")
    start = sim.clock.now()
    scanner.write("INIT")
    first = scanner.query("FETC?")
    assert sim.clock.now() - start == pytest.approx(0.2)
    assert len(first.split(",")) == 2 and scanner.query("FETC?") == first


def test_nplc_sets_the_integration_time_per_channel(sim):
    scanner = sim.serial("daq970a", LINK)
    scanner.write("CONF:TEMP TC,K,(@101:102)")
    scanner.write("SENS:TEMP:NPLC 10,(@102)")
    scanner.write("SENS:TEMP:NPLC 3,(@101)")  # rounded up to 10
    assert scanner.query("SENS:TEMP:NPLC? (@101,102)") == "+1.00000000E+01,+1.00000000E+01"
    start = sim.clock.now()
    scanner.query("READ?")
    assert sim.clock.now() - start == pytest.approx(2 * 10 / 50)


def test_relays_open_and_close_and_a_scan_opens_them(sim):
    scanner = sim.serial("daq970a", LINK)
    scanner.write("ROUT:CLOS (@105,107)")
    assert scanner.query("ROUT:CLOS? (@105:107)") == "1,0,1"
    assert scanner.query("ROUT:OPEN? (@105:107)") == "0,1,0"
    scanner.write("ROUT:OPEN (@105)")
    assert scanner.query("ROUT:CLOS? (@105,107)") == "0,1"
    assert scanner.query("DIAG:REL:CYCL? (@105,107)") == "+1,+1"


@pytest.mark.parametrize("instrument, slot1, slot2", [
    ("daq970a", "Keysight Technologies,DAQM901A,0,1.0", "Keysight Technologies,0,0,0"),
    ("34970a", "HEWLETT-PACKARD,34901A,0,1.0", "HEWLETT-PACKARD,0,0,0"),
])
def test_card_type_names_the_module_or_an_empty_slot(sim, instrument, slot1, slot2):
    scanner = sim.serial(instrument, LINK)
    assert scanner.query("SYST:CTYP? 100") == slot1
    assert scanner.query("SYST:CTYP? 200") == slot2


# -- HMP4040 additions -----------------------------------------------------------------------------------

def test_min_max_queries_answer_the_limits_not_the_setting(link):
    link.write("VOLT 12")
    assert [link.query(q) for q in ("VOLT?", "VOLT? MIN", "VOLT? MAX", "CURR? MAX")] == [
        "12.000", "0.000", "32.050", "10.0100"]
    link.write("VOLT MAX")
    assert link.query("VOLT?") == "32.050"


def test_apply_and_steps(link):
    link.write("INST OUT3;APPL 5, 0.5")
    assert link.query("APPL?") == "5.000,0.5000"
    link.write("VOLT:STEP 0.25;:VOLT UP;:VOLT UP")  # a leading colon: back to the root
    assert link.query("VOLT?;VOLT:STEP?") == "5.500;0.250"
    link.write("CURR:STEP 0.2;:CURR DOWN")
    assert link.query("CURR?") == "0.3000"
    link.write("VOLT 0;VOLT DOWN")  # below zero: refused
    assert link.query("SYST:ERR?") == '-222,"Data out of range"'
    assert link.query("SYST:VERS?") == "1999.0"


def test_power_ovp_and_fuse(sim, link):
    link.write("INST OUT1;APPL 12,2;OUTP ON")
    load = sim.lab.config.thermal.target_heater_ohm
    assert float(link.query("MEAS:POW?")) == pytest.approx(12 * 12 / load, rel=1e-3)
    link.write("VOLT:PROT 10")  # below the 12 V it delivers: trips
    assert link.query("VOLT:PROT:TRIP?") == "1" and not sim.lab.supply[1].on
    for command in ("VOLT:PROT:CLE", "VOLT:PROT 32", "CURR 1", "FUSE ON", "OUTP ON"):  # 12 V / 8 Ohm > 1 A
        link.write(command)
    assert link.query("FUSE:TRIP?") == "1" and not sim.lab.supply[1].on
    assert link.query("SYST:ERR?") == '+0,"No error"'
