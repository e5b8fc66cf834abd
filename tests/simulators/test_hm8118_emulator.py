"""The HM8118 emulator over a real serial link: the remote command list, terminators, pacing [M32, M23, SWM]."""

from __future__ import annotations

import pytest

from ecds_lab.simulators.hm8118 import COMMAND_TIME_S

PAUSE_S = 0.2  # what the driver and the R&S example keep between commands


@pytest.fixture
def bridge(sim):
    """Write raw bytes to the bridge and read its CR-terminated replies, pausing like a paced host."""

    class Port:
        def __init__(self) -> None:
            from ecds_lab.drivers.hm8118 import SERIAL_SETTINGS

            self.link = sim.serial("hm8118", SERIAL_SETTINGS, min_interval_s=0.0)
            self.emulator = sim.emulator("hm8118")

        def send(self, data: bytes) -> None:
            sim.clock.sleep(PAUSE_S)
            self.link.port.write(data)

        def ask(self, data: bytes) -> bytes:
            self.send(data)
            reply = bytearray()
            while not reply.endswith(b"\r"):
                reply += self.link.port.read(1)
            return bytes(reply)

    return Port()


@pytest.mark.parametrize("setting, value, reply", [
    (b"LOCK", b"1", b"1\r"), (b"RNGH", b"1", b"1\r"), (b"OUTP", b"2", b"2\r"), (b"BIAS", b"1", b"1\r"),
    (b"VBIA", b"2.5", b"2.500\r"), (b"$STL", b"1500", b"1500\r"), (b"CONV", b"1", b"1\r"), (b"RNGE", b"4", b"4\r"),
    (b"AVGM", b"2", b"2\r"), (b"PREL", b"0.05", b"0.05000\r"),
])
def test_settings_a_third_party_client_sends_are_taken_silently_and_read_back(bridge, setting, value, reply):
    bridge.send(setting + b" " + value + b"\r")
    assert bridge.ask(setting + b"?\r") == reply


@pytest.mark.parametrize("command", [b"LOCK 2\r", b"VBIA 5.1\r", b"BIAS 3\r", b"$STL 40001\r", b"RNGE 7\r",
                                     b"AVGM 3\r", b"BING 1\r", b"CONV\r"])
def test_values_outside_the_command_list_are_refused(bridge, command):
    assert bridge.ask(command) == b"ERROR\r"


def test_a_client_that_never_reads_set_replies_stays_in_step(bridge):
    """SweepMe!'s set-up: LOCK, CIRC, RNGH, OUTP, VBIA, BIAS are answered with nothing, so FREQ? gets its own reply."""
    for command in (b"*RST\r", b"LOCK 1\r", b"CIRC 1\r", b"RNGH 0\r", b"OUTP 0\r", b"VBIA 1.000e+00\r", b"BIAS 1\r",
                    b"FREQ 1.00000e+03\r"):
        bridge.send(command)
    assert bridge.ask(b"FREQ?\r") == b"1000\r"
    assert bridge.ask(b"VBIA?\r") == b"1.000\r"


def test_range_hold_keeps_the_range_auto_ranging_follows_the_coil(bridge):
    bridge.send(b"PMOD 8\r")
    bridge.ask(b"XALL?\r")
    auto = int(bridge.ask(b"RNGE?\r"))
    assert auto == bridge.emulator.auto_range(abs(bridge.emulator.lab.coil_impedance(1000)))
    bridge.send(b"RNGE 6\r")  # choosing a range holds it
    assert bridge.ask(b"RNGH?\r") == b"1\r"
    bridge.ask(b"XALL?\r")
    assert bridge.ask(b"RNGE?\r") == b"6\r"
    bridge.send(b"RNGH 0\r")
    bridge.ask(b"XALL?\r")
    assert int(bridge.ask(b"RNGE?\r")) == auto


def test_cr_lf_ends_a_command_a_lone_lf_does_not(bridge):
    bridge.send(b"FREQ 2000\r\n")
    assert bridge.ask(b"FREQ?\r\n") == b"2000\r"
    bridge.send(b"FREQ 5000\n")  # no command yet: the LF is part of the line
    assert bridge.ask(b"FREQ?\r") == b"ERROR\r"  # "FREQ 5000\nFREQ?" is garbage
    assert bridge.ask(b"FREQ?\r") == b"2000\r"


def test_a_command_sent_faster_than_the_bridge_takes_them_is_lost(sim, bridge):
    bridge.send(b"FREQ 3000\r")
    sim.clock.sleep(COMMAND_TIME_S / 2)
    bridge.link.port.write(b"FREQ 4000\r")  # too soon: lost
    assert bridge.emulator.lost_lines == ["FREQ 4000"]
    assert bridge.ask(b"FREQ?\r") == b"3000\r"


def test_averaging_modes_cost_their_readings(sim, bridge):
    for command in (b"PMOD 2\r", b"RATE 0\r", b"MMOD 1\r", b"AVGM 1\r", b"NAVG 10\r"):
        bridge.send(command)
    bridge.send(b"*TRG\r")
    start = sim.clock.now()
    bridge.ask(b"XALL?\r")
    assert sim.clock.now() - start == pytest.approx(10 * 0.07, abs=0.01)  # from *TRG to the reply
    bridge.send(b"AVGM 2\r")  # median of three
    bridge.send(b"*TRG\r")
    start = sim.clock.now()
    bridge.ask(b"XMAJ?\r")
    assert sim.clock.now() - start == pytest.approx(3 * 0.07, abs=0.01)


def test_trigger_delay_adds_to_the_measurement(sim, bridge):
    for command in (b"PMOD 2\r", b"RATE 0\r", b"MMOD 1\r", b"$STL 1000\r", b"*TRG\r"):
        bridge.send(command)
    start = sim.clock.now()
    bridge.ask(b"*OPC?\r")
    assert sim.clock.now() - start == pytest.approx(1.07, abs=0.01)  # from *TRG to the reply


def test_deviation_reads_need_a_reference(bridge):
    bridge.send(b"PMOD 6\r")  # Z-theta
    assert bridge.ask(b"XDLT?\r") == b"ERROR\r"  # PREL is 0
    z = float(bridge.ask(b"XMAJ?\r"))
    bridge.send(b"PREL " + f"{z:.5f}".encode() + b"\r")
    assert abs(float(bridge.ask(b"XDLT?\r"))) < 0.01 * z
    assert abs(float(bridge.ask(b"XDMT?\r"))) < 1.0  # percent


def test_the_output_mode_shows_the_main_value_as_a_deviation(bridge):
    bridge.send(b"PMOD 6\r")
    bridge.send(b"OUTP 2\r")  # percent deviation from PREL, which is 0: nothing to show [M23]
    assert bridge.ask(b"XMAJ?\r") == b"ERROR\r"
    bridge.send(b"OUTP 0\r")
    z = float(bridge.ask(b"XMAJ?\r"))
    bridge.send(b"PREL " + f"{z / 2:.5f}".encode() + b"\r")
    bridge.send(b"OUTP 2\r")
    assert float(bridge.ask(b"XALL?\r").split(b",")[0]) == pytest.approx(100.0, abs=2.0)
    bridge.send(b"OUTP 1\r")
    assert float(bridge.ask(b"XMAJ?\r")) == pytest.approx(z / 2, rel=0.02)


def test_trigger_and_opc_in_one_line_answer_when_the_reading_is_done(sim, bridge):
    """SweepMe!'s measure step: "*TRG; *OPC?" then XALL? [SWM]."""
    for command in (b"PMOD 8\r", b"RATE 2\r", b"MMOD 1\r"):
        bridge.send(command)
    start = sim.clock.now() + PAUSE_S
    assert bridge.ask(b"*TRG; *OPC?\r") == b"1\r"
    assert sim.clock.now() - start == pytest.approx(0.6, abs=0.01)
    real, imaginary, bin_number = bridge.ask(b"XALL?\r").rstrip(b"\r").split(b",")
    assert float(real) > 0 and float(imaginary) > 0 and bin_number == b"0"


def test_a_listed_command_in_any_case_gets_the_same_answer(bridge):
    assert bridge.ask(b"*idn?\r") == bridge.ask(b"*IDN?\r") == b"HAMEG Instruments, HM8118,013206727,1.57\r"


def test_an_injected_refusal_reaches_a_listed_command_too(sim, bridge):
    bridge.send(b"PMOD 8\r")  # R-X: a function with something to read
    sim.lab.faults.bridge_error_commands.add("XALL")
    assert bridge.ask(b"XALL?\r") == b"ERROR\r"
    sim.lab.faults.bridge_error_commands.clear()
    assert bridge.ask(b"XALL?\r") != b"ERROR\r"
