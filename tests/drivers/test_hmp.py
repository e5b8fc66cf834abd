"""HMP4040 driver against its emulator through pyserial and pyvisa: exact bytes, heating, errors, safe state."""

from __future__ import annotations

import pytest

from ecds_lab.drivers.daq970a import DAQ970A
from ecds_lab.drivers.daq970a import SERIAL_SETTINGS as DAQ_SERIAL
from ecds_lab.drivers.hmp import HMP4040, SERIAL_SETTINGS, VISA_SETTINGS
from ecds_lab.errors import InstrumentError, InvalidSettingError
from ecds_lab.instruments import HeaterSupply
from ecds_lab.transports.visa_link import VisaTransport


@pytest.fixture
def supply(sim):
    return HMP4040(sim.serial("hmp4040", SERIAL_SETTINGS))


def test_link_settings():
    assert SERIAL_SETTINGS["write_termination"] == VISA_SETTINGS["write_termination"] == "\n"
    assert SERIAL_SETTINGS["rtscts"] is True


def test_is_a_heater_supply(supply):
    assert isinstance(supply, HeaterSupply)
    assert (supply.max_voltage_v, supply.max_current_a, supply.max_power_w) == (32.0, 10.0, 160.0)


def test_identity_accepts_both_vendors(sim, supply):
    assert supply.identity().startswith("ROHDE&SCHWARZ,HMP4040") and supply.detected_model == "HMP4040"
    sim.emulator("hmp4040").identity = "HAMEG,HMP4030,012345678,HW50020001/SW2.30"
    assert supply.identity().startswith("HAMEG") and supply.detected_model == "HMP4030"


def test_identity_refuses_another_instrument(sim):
    with pytest.raises(InstrumentError, match="not a Hameg / Rohde & Schwarz HMP"):
        HMP4040(sim.serial("daq970a", SERIAL_SETTINGS)).identity()


def test_set_output_sends_exact_bytes(sim, supply):
    wire = sim.capture("hmp4040")
    supply.set_output(1, 12.0, 2.0)
    assert bytes(wire) == b"INST OUT1\nVOLT 12.000\nCURR 2.0000\nSYST:ERR?\n"
    assert (sim.lab.supply[1].voltage_v, sim.lab.supply[1].current_limit_a) == (12.0, 2.0)
    assert not sim.lab.supply[1].on


def test_enable_and_read_back_match_the_heater(sim, supply):
    supply.set_output(1, 12.0, 2.0)
    wire = sim.capture("hmp4040")
    supply.enable(1, True)
    assert bytes(wire) == b"INST OUT1\nOUTP ON\nSYST:ERR?\n"
    assert sim.lab.supply[1].on
    wire.clear()
    volts, amps = supply.read_back(1)
    assert bytes(wire) == b"INST OUT1\nMEAS:VOLT?\nMEAS:CURR?\n"
    load = sim.lab.config.thermal.target_heater_ohm
    assert (volts, amps) == (pytest.approx(12.0), pytest.approx(12.0 / load))
    supply.enable(1, False)
    assert not sim.lab.supply[1].on and supply.read_back(1) == (0.0, 0.0)


def test_current_limit_holds_the_current(sim, supply):
    supply.set_output(1, 12.0, 1.0)
    supply.enable(1, True)
    assert supply.read_back(1) == (pytest.approx(8.0), pytest.approx(1.0))  # 1 A into 8 Ohm


def test_heater_warms_the_target(sim, supply):
    scanner = DAQ970A(sim.serial("daq970a", DAQ_SERIAL))
    scanner.configure()
    before = scanner.read_temperatures_c()
    supply.set_output(1, 16.0, 2.5)  # 2 A into 8 Ohm: 32 W
    supply.enable(1, True)
    sim.clock.sleep(1800)
    after = scanner.read_temperatures_c()
    assert after["target"] - before["target"] > 25  # 32 K/W * (1 - e^-3) ~ 30 K
    assert after["ambient"] == pytest.approx(22.0, abs=0.2)
    assert after["coil"] == pytest.approx(22.0, abs=0.2)  # the box heater is output 2


@pytest.mark.parametrize("output, volts, amps, message", [
    (0, 1.0, 1.0, r"selected_output: 0 is outside the allowed 1..4"),
    (5, 1.0, 1.0, r"selected_output: 5 is outside the allowed 1..4"),
    (1.5, 1.0, 1.0, r"selected_output: 1.5 is not a whole number"),
    (1, 33.0, 1.0, r"voltage_v: 33 V is outside the allowed 0..32 V"),
    (1, -0.5, 1.0, r"voltage_v: -0.5 V is outside"),
    (1, 5.0, 10.5, r"current_limit_a: 10.5 A is outside the allowed 0..10 A"),
    (1, 20.0, 9.0, r"180 W exceeds the 160 W"),
])
def test_bad_settings_raise_before_anything_is_sent(sim, supply, output, volts, amps, message):
    wire = sim.capture("hmp4040")
    with pytest.raises(InvalidSettingError, match=message):
        supply.set_output(output, volts, amps)
    assert bytes(wire) == b""


def test_bad_output_numbers_send_nothing(sim):
    supply = HMP4040(sim.serial("hmp4040", SERIAL_SETTINGS), outputs=3)
    wire = sim.capture("hmp4040")
    with pytest.raises(InvalidSettingError, match=r"outside the allowed 1\.\.3"):
        supply.enable(4, True)
    with pytest.raises(InvalidSettingError):
        supply.read_back(0)
    assert bytes(wire) == b""


def test_instrument_refusal_surfaces_with_the_error_queue_text(sim):
    """A driver told the wrong limits lets 40 V through; the supply refuses it and keeps 0 V."""
    supply = HMP4040(sim.serial("hmp4040", SERIAL_SETTINGS), max_voltage_v=40.0)
    with pytest.raises(InstrumentError, match=r"'INST OUT1; VOLT 35.000; CURR 1.0000'.*-222,\"Data out of range\""):
        supply.set_output(1, 35.0, 1.0)
    assert sim.lab.supply[1].voltage_v == 0.0
    assert sim.lab.supply[1].current_limit_a == 1.0  # the CURR after the refused VOLT was accepted


def test_controls_check_the_error_queue_after_each_set(sim, supply):
    wire = sim.capture("hmp4040")
    supply.selected_output = 2
    supply.voltage_v = 5
    supply.master = True
    assert bytes(wire) == b"INST OUT2\nSYST:ERR?\nVOLT 5.000\nSYST:ERR?\nOUTP:GEN ON\nSYST:ERR?\n"
    assert supply.selected_output == 2 and supply.voltage_v == 5.0 and supply.master is True
    assert supply.armed is False and not sim.lab.supply[2].on  # master alone switches nothing


def test_master_switch_needs_an_armed_output(sim, supply):
    supply.set_output(2, 8.0, 1.5)
    supply.selected_output = 2
    supply.armed = True
    assert not sim.lab.supply[2].on
    supply.master = True
    assert sim.lab.supply[2].on and supply.output is True
    supply.master = False
    assert not sim.lab.supply[2].on and supply.armed is True


def test_all_off_switches_every_output_off(sim, supply):
    for output in (1, 2):
        supply.set_output(output, 10.0, 2.0)
        supply.enable(output, True)
    wire = sim.capture("hmp4040")
    supply.all_off()
    assert bytes(wire) == (b"OUTP:GEN OFF\nINST OUT1\nOUTP:SEL OFF\nINST OUT2\nOUTP:SEL OFF\n"
                           b"INST OUT3\nOUTP:SEL OFF\nINST OUT4\nOUTP:SEL OFF\n")
    assert not any(output.on for output in sim.lab.supply.values())
    supply.enable(1, True)  # switching one output on again does not revive the other
    assert sim.lab.supply[1].on and not sim.lab.supply[2].on


def test_all_off_works_after_failed_commands(sim):
    supply = HMP4040(sim.serial("hmp4040", SERIAL_SETTINGS), max_voltage_v=40.0)
    supply.set_output(1, 10.0, 2.0)
    supply.enable(1, True)
    supply.write("VOLT 99")  # leaves an error in the queue
    supply.write("INST OUT9")
    with pytest.raises(InstrumentError):
        supply.set_output(1, 35.0, 2.0)
    supply.write("BOGUS:COMMAND")
    supply.all_off()
    assert not sim.lab.supply[1].on


def test_through_pyvisa(sim):
    """pyvisa-py opens ASRL<url>::INSTR with pyserial's serial_for_url, so this is the full VISA stack."""
    link = VisaTransport("hmp4040", "ASRL" + sim.url("hmp4040") + "::INSTR", clock=sim.clock, **VISA_SETTINGS)
    supply = HMP4040(link)
    wire = sim.capture("hmp4040")
    assert "HMP4040" in supply.identity()
    supply.set_output(1, 16.0, 2.5)
    supply.enable(1, True)
    assert supply.read_back(1) == (pytest.approx(16.0), pytest.approx(2.0))
    supply.all_off()
    assert bytes(wire).startswith(b"*IDN?\nINST OUT1\nVOLT 16.000\nCURR 2.5000\nSYST:ERR?\nINST OUT1\nOUTP ON\n")
    assert not sim.lab.supply[1].on
    link.close()


# -- every command the driver sends, byte for byte against literal replies (no simulator) --------------------
# INST OUT<n> selects, VOLT/CURR set the selected output, OUTP/OUTP:SEL/OUTP:GEN switch, MEAS:VOLT?/MEAS:CURR?
# read back [pym-HMP, qc-HMP, chk]; SYST:ERR? after each set (SCPI-1999); LF-terminated [qc-HMP].

def _supply(pairs, **options):
    from ecds_lab.testing import expected_protocol

    return expected_protocol(HMP4040, pairs, link_settings=VISA_SETTINGS, **options)


NO_ERROR = b'0,"No error"\n'


def test_protocol_identity_set_enable_read_back_and_all_off():
    pairs = [
        (b"*IDN?\n", b"ROHDE&SCHWARZ,HMP4040,101234,HW50020003/SW2.51\n"),
        (b"INST OUT2\n", None), (b"VOLT 12.000\n", None), (b"CURR 1.5000\n", None), (b"SYST:ERR?\n", NO_ERROR),
        (b"INST OUT2\n", None), (b"OUTP ON\n", None), (b"SYST:ERR?\n", NO_ERROR),
        (b"INST OUT2\n", None), (b"MEAS:VOLT?\n", b"12.000\n"), (b"MEAS:CURR?\n", b"1.5000\n"),
        (b"OUTP:GEN OFF\n", None),
        (b"INST OUT1\n", None), (b"OUTP:SEL OFF\n", None), (b"INST OUT2\n", None), (b"OUTP:SEL OFF\n", None),
    ]
    with _supply(pairs, outputs=2) as supply:
        supply.identity()
        supply.set_output(2, 12.0, 1.5)
        supply.enable(2, True)
        assert supply.read_back(2) == (12.0, 1.5)
        supply.all_off()


def test_protocol_each_control_sets_checks_errors_and_reads_back():
    pairs = [
        (b"INST OUT3\n", None), (b"SYST:ERR?\n", NO_ERROR), (b"INST:NSEL?\n", b"3\n"),
        (b"OUTP:SEL ON\n", None), (b"SYST:ERR?\n", NO_ERROR), (b"OUTP:SEL?\n", b"1\n"),
        (b"OUTP:GEN ON\n", None), (b"SYST:ERR?\n", NO_ERROR), (b"OUTP:GEN?\n", b"1\n"),
        (b"OUTP OFF\n", None), (b"SYST:ERR?\n", NO_ERROR), (b"OUTP?\n", b"0\n"),
        (b"VOLT?\n", b"5.000\n"), (b"CURR?\n", b"0.1000\n"),
    ]
    with _supply(pairs) as supply:
        supply.selected_output = 3
        assert supply.selected_output == 3
        supply.armed = True
        assert supply.armed is True
        supply.master = True
        assert supply.master is True
        supply.output = False
        assert supply.output is False
        assert (supply.voltage_v, supply.current_limit_a) == (5.0, 0.1)


def test_protocol_a_refused_set_names_the_commands_and_the_error():
    pairs = [(b"INST OUT1\n", None), (b"VOLT 31.000\n", None), (b"CURR 1.0000\n", None),
             (b"SYST:ERR?\n", b'-222,"Data out of range"\n'), (b"SYST:ERR?\n", NO_ERROR)]
    with _supply(pairs) as supply, pytest.raises(InstrumentError, match=r"VOLT 31.000.*-222"):
        supply.set_output(1, 31.0, 1.0)
