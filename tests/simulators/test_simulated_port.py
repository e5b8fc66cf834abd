"""The ``ecdssim://`` serial port as pyserial's contract has it: replies byte by byte or in one read, a
timeout on the simulated clock, and nothing served once the port is closed."""

from __future__ import annotations

import pytest
import serial
from serial.serialutil import PortNotOpenError, SerialTimeoutException

from ecds_lab.simulators.hm8118 import IDENTITY


@pytest.fixture
def port(sim):
    opened = serial.serial_for_url(sim.url("hm8118"), timeout=2.0)
    yield opened
    opened.close()


def test_a_reply_read_one_byte_at_a_time_as_pyvisa_py_reads(port):
    port.write(b"*IDN?\r")
    reply = b""
    while not reply.endswith(b"\r"):
        reply += port.read(1)
    assert reply == IDENTITY.encode("ascii") + b"\r"
    assert port.in_waiting == 0


def test_a_reply_taken_whole_after_its_first_byte(port):
    port.write(b"*IDN?\r")
    first = port.read(1)
    rest = port.read(port.in_waiting)
    assert first + rest == IDENTITY.encode("ascii") + b"\r"


def test_no_reply_is_a_timeout_after_the_port_timeout_on_the_simulated_clock(sim, port):
    before = sim.clock.now()
    with pytest.raises(SerialTimeoutException, match=r"no reply within 2\.0 s"):
        port.read(1)
    assert sim.clock.now() - before == pytest.approx(2.0)


def test_a_closed_port_serves_nothing_even_with_reply_bytes_left(port):
    port.write(b"*IDN?\r")
    port.read(1)  # the rest of the reply is waiting
    port.close()
    with pytest.raises(PortNotOpenError):
        port.read(1)
    with pytest.raises(PortNotOpenError):
        port.in_waiting  # noqa: B018 - the property's access is what is tested
