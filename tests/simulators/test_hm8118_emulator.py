"""The HM8118 emulator over a real serial link, byte for byte.

The first tests state what the manual pages cited in simulators/hm8118.py say (ch. 10 [M68], the German
command list [D23], measurement speed [D12], ranges [E51]); the later ones pin what the emulator ASSUMES
where the stored manual pages are silent, so that a change to an assumption is a visible decision.
"""

from __future__ import annotations

import pytest

from ecds_lab.simulators.hm8118 import COMMAND_TIME_S, MEASUREMENT_TIME_S

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


# -- what the manual pages say ---------------------------------------------------------------------------

@pytest.mark.parametrize("rate, seconds", [(b"0", 1 / 14), (b"1", 1 / 8), (b"2", 0.6)])
def test_one_reading_takes_the_manuals_time_per_speed(sim, bridge, rate, seconds):
    """14 readings per second at FAST and 8 at MED [D12]; SLOW 0.6 s (the manual: "about 1.5 per second"; the
    pinned run readings keep 0.6 s). *OPC? answers 1 once the reading is complete [M68 10.2]."""
    for command in (b"PMOD 2\r", b"RATE " + rate + b"\r", b"MMOD 1\r"):
        bridge.send(command)
    start = sim.clock.now() + PAUSE_S
    assert bridge.ask(b"*TRG; *OPC?\r") == b"1\r"
    assert sim.clock.now() - start == pytest.approx(seconds, abs=1e-9)
    assert MEASUREMENT_TIME_S[int(rate)] == pytest.approx(seconds)


@pytest.mark.parametrize("query", [b"XMAJ?\r", b"XMIN?\r", b"XDLT?\r", b"XDMT?\r", b"XALL?\r"])
def test_reading_queries_in_the_auto_function_are_errors(bridge, query):
    """XMAJ?, XMIN?, XDLT?, XDMT?: an error message when the function is AUTO [D23] (XALL? likewise: ASSUMED)."""
    bridge.send(b"PMOD 0\r")
    bridge.send(b"PREL 0.05\r")  # a reference, so that the deviation queries fail for AUTO alone
    assert bridge.ask(query) == b"ERROR\r"


@pytest.mark.parametrize("command", [b"BING?\r", b"BING 1\r", b"BLIH 1,5\r", b"BCLR\r"])
def test_binning_needs_the_ho118_interface(bridge, command):
    """The binning command list exists only with the HO118 binning interface fitted [D23]; this bridge has none."""
    assert bridge.ask(command) == b"ERROR\r"


@pytest.mark.parametrize("code", [b"1", b"2", b"3", b"4", b"5", b"6"])
def test_six_measurement_ranges(bridge, code):
    """Ranges 1 to 6 [E51 6.4]: each is held and read back; there is no range 0 or 7."""
    bridge.send(b"RNGE " + code + b"\r")
    assert bridge.ask(b"RNGE?\r") == code + b"\r"
    assert bridge.ask(b"RNGE 0\r") == b"ERROR\r"
    assert bridge.ask(b"RNGE 7\r") == b"ERROR\r"


def test_a_held_range_far_below_the_component_reads_overrange(bridge):
    """With the range held and the component's impedance more than 100 times the range's nominal value, the bridge
    shows OVERRANGE [E51 6.4] (over the link: ERROR, and the range's auto-ranging limit as its nominal, ASSUMED).
    The coil at 15 kHz is about 5 kOhm: range 1 (3 Ohm) is far below it, range 5 and auto ranging read it."""
    bridge.send(b"PMOD 2\r")
    bridge.send(b"FREQ 15000\r")
    bridge.send(b"RNGE 1\r")
    assert bridge.ask(b"XALL?\r") == b"ERROR\r"
    assert bridge.ask(b"XMAJ?\r") == b"ERROR\r"
    bridge.send(b"RNGE 5\r")
    inductance, _, _ = bridge.ask(b"XALL?\r").rstrip(b"\r").split(b",")
    assert 0.04 < float(inductance) < 0.07
    bridge.send(b"RNGE 1\r")
    bridge.send(b"RNGH 0\r")
    assert bridge.ask(b"XALL?\r") != b"ERROR\r"


def test_identity_has_the_manuals_fields(bridge):
    """*IDN?: HAMEG Instruments, instrument type, serial number, firmware [M68 10.2]."""
    maker, model, serial, firmware = bridge.ask(b"*IDN?\r").rstrip(b"\r").split(b",")
    assert (maker, model) == (b"HAMEG Instruments", b" HM8118")
    assert serial.isdigit() and firmware.replace(b".", b"").isdigit()


def test_the_reference_keeps_five_decimals(bridge):
    """A reference value is entered with up to five digits after the point [E51 6.3]."""
    bridge.send(b"PREL 0.123456\r")
    assert bridge.ask(b"PREL?\r") == b"0.12346\r"


# -- what the emulator assumes where the stored pages are silent ------------------------------------------

@pytest.mark.parametrize("setting, value, reply", [
    (b"LOCK", b"1", b"1\r"), (b"RNGH", b"1", b"1\r"), (b"OUTP", b"2", b"2\r"), (b"BIAS", b"1", b"1\r"),
    (b"VBIA", b"2.5", b"2.500\r"), (b"$STL", b"1500", b"1500\r"), (b"CONV", b"1", b"1\r"), (b"RNGE", b"4", b"4\r"),
    (b"AVGM", b"2", b"2\r"), (b"PREL", b"0.05", b"0.05000\r"),
])
def test_assumed_settings_are_taken_silently_and_read_back(bridge, setting, value, reply):
    """LOCK, RNGH, OUTP, BIAS, VBIA, $STL, CONV, AVGM: ASSUMED (no stored manual page lists them); RNGE 1-6 [E51]."""
    bridge.send(setting + b" " + value + b"\r")
    assert bridge.ask(setting + b"?\r") == reply


@pytest.mark.parametrize("command", [b"LOCK 2\r", b"VBIA 5.1\r", b"BIAS 3\r", b"$STL 40001\r", b"RNGE 7\r",
                                     b"AVGM 3\r", b"BING 1\r", b"CONV\r"])
def test_values_outside_the_assumed_ranges_are_refused(bridge, command):
    """RNGE 7 is beyond the six ranges [E51]; BING needs the HO118 binning interface [D23]; the rest ASSUMED."""
    assert bridge.ask(command) == b"ERROR\r"


def test_a_client_that_never_reads_set_replies_stays_in_step(bridge):
    """Accepted set commands answer nothing (ASSUMED), so a query after a run of them gets its own reply."""
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
    """Each command ends with CR or CR+LF, "no individual LF" [M68 10.1]."""
    bridge.send(b"FREQ 2000\r\n")
    assert bridge.ask(b"FREQ?\r\n") == b"2000\r"
    bridge.send(b"FREQ 5000\n")  # no command yet: the LF is part of the line
    assert bridge.ask(b"FREQ?\r") == b"ERROR\r"  # "FREQ 5000\nFREQ?" is garbage
    assert bridge.ask(b"FREQ?\r") == b"2000\r"


def test_a_command_sent_faster_than_the_bridge_takes_them_is_lost(sim, bridge):
    """No parallel processing of commands [M68 10.2]; the time to take in one (0.1 s) and the loss are ASSUMED."""
    bridge.send(b"FREQ 3000\r")
    sim.clock.sleep(COMMAND_TIME_S / 2)
    bridge.link.port.write(b"FREQ 4000\r")  # too soon: lost
    assert bridge.emulator.lost_lines == ["FREQ 4000"]
    assert bridge.ask(b"FREQ?\r") == b"3000\r"


def test_averaging_modes_cost_their_readings(sim, bridge):
    """Averaging NAVG readings, or the median of three (both ASSUMED), at FAST: 1/14 s per reading [D12]."""
    for command in (b"PMOD 2\r", b"RATE 0\r", b"MMOD 1\r", b"AVGM 1\r", b"NAVG 10\r"):
        bridge.send(command)
    bridge.send(b"*TRG\r")
    start = sim.clock.now()
    bridge.ask(b"XALL?\r")
    assert sim.clock.now() - start == pytest.approx(10 / 14, abs=1e-9)  # from *TRG to the reply
    bridge.send(b"AVGM 2\r")  # median of three
    bridge.send(b"*TRG\r")
    start = sim.clock.now()
    bridge.ask(b"XMAJ?\r")
    assert sim.clock.now() - start == pytest.approx(3 / 14, abs=1e-9)


def test_trigger_delay_adds_to_the_measurement(sim, bridge):
    """$STL in ms (ASSUMED) before a FAST reading of 1/14 s [D12]."""
    for command in (b"PMOD 2\r", b"RATE 0\r", b"MMOD 1\r", b"$STL 1000\r", b"*TRG\r"):
        bridge.send(command)
    start = sim.clock.now()
    bridge.ask(b"*OPC?\r")
    assert sim.clock.now() - start == pytest.approx(1.0 + 1 / 14, abs=1e-9)  # from *TRG to the reply


def test_the_relative_deviation_needs_a_reference_the_absolute_one_does_not(bridge):
    """XDMT? (relative) is an error with a zero nominal value; XDLT? (absolute) only in AUTO [E71]."""
    bridge.send(b"PMOD 6\r")  # Z-theta
    assert bridge.ask(b"XDMT?\r") == b"ERROR\r"  # PREL is 0
    z = float(bridge.ask(b"XMAJ?\r"))
    assert float(bridge.ask(b"XDLT?\r")) == pytest.approx(z, rel=0.02)  # the deviation from zero is the value
    bridge.send(b"PREL " + f"{z:.5f}".encode() + b"\r")
    assert abs(float(bridge.ask(b"XDLT?\r"))) < 0.01 * z
    assert abs(float(bridge.ask(b"XDMT?\r"))) < 1.0  # percent


def test_the_output_mode_shows_the_main_value_as_a_deviation(bridge):
    """∆ABS and ∆% from the reference [E51 6.3]; an error in ∆% with a zero reference [D23]; OUTP codes ASSUMED."""
    bridge.send(b"PMOD 6\r")
    bridge.send(b"OUTP 2\r")  # percent deviation from PREL, which is 0: nothing to show [D23]
    assert bridge.ask(b"XMAJ?\r") == b"ERROR\r"
    bridge.send(b"OUTP 0\r")
    z = float(bridge.ask(b"XMAJ?\r"))
    bridge.send(b"PREL " + f"{z / 2:.5f}".encode() + b"\r")
    bridge.send(b"OUTP 2\r")
    assert float(bridge.ask(b"XALL?\r").split(b",")[0]) == pytest.approx(100.0, abs=2.0)
    bridge.send(b"OUTP 1\r")
    assert float(bridge.ask(b"XMAJ?\r")) == pytest.approx(z / 2, rel=0.02)


def test_trigger_and_opc_in_one_line_answer_when_the_reading_is_done(sim, bridge):
    """A ';'-joined string (the manual recommends avoiding them [M68 10.1]; accepting them is ASSUMED): *OPC?
    answers 1 once the SLOW reading is complete [M68 10.2]."""
    for command in (b"PMOD 8\r", b"RATE 2\r", b"MMOD 1\r"):
        bridge.send(command)
    start = sim.clock.now() + PAUSE_S
    assert bridge.ask(b"*TRG; *OPC?\r") == b"1\r"
    assert sim.clock.now() - start == pytest.approx(0.6, abs=0.01)
    real, imaginary, bin_number = bridge.ask(b"XALL?\r").rstrip(b"\r").split(b",")
    assert float(real) > 0 and float(imaginary) > 0
    assert bin_number == b"99"  # no binning interface fitted [E71]


def test_a_listed_command_in_any_case_gets_the_same_answer(bridge):
    assert bridge.ask(b"*idn?\r") == bridge.ask(b"*IDN?\r") == b"HAMEG Instruments, HM8118,013206727,1.57\r"


def test_an_injected_refusal_reaches_a_listed_command_too(sim, bridge):
    bridge.send(b"PMOD 8\r")  # R-X: a function with something to read
    sim.lab.faults.bridge_error_commands.add("XALL")
    assert bridge.ask(b"XALL?\r") == b"ERROR\r"
    sim.lab.faults.bridge_error_commands.clear()
    assert bridge.ask(b"XALL?\r") != b"ERROR\r"
