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
