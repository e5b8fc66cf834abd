"""DAQ970A / 34970A driver against its emulators through pyserial and pyvisa: exact bytes, errors, validation."""

from __future__ import annotations

import pytest

from ecds_lab.drivers.daq970a import DAQ970A, SERIAL_SETTINGS, VISA_SETTINGS, Keysight34970A, channel_list
from ecds_lab.errors import InstrumentError, InvalidSettingError
from ecds_lab.instruments import TemperatureScanner
from ecds_lab.transports.visa_link import VisaTransport

CONFIGURE_BYTES = (
    b"CONF:TEMP TC,K,(@101:103)\nUNIT:TEMP C,(@101:103)\nSENS:TEMP:TRAN:TC:RJUN:TYPE INT,(@101:103)\n"
    b"SENS:TEMP:TRAN:TC:CHEC ON,(@101:103)\nROUT:SCAN (@101:103)\nSYST:ERR?\n"
)


@pytest.fixture
def scanner(sim):
    return DAQ970A(sim.serial("daq970a", SERIAL_SETTINGS))


def test_link_settings():
    assert SERIAL_SETTINGS["baudrate"] == 9600 and SERIAL_SETTINGS["parity"] == "N"
    assert SERIAL_SETTINGS["write_termination"] == VISA_SETTINGS["write_termination"] == "\n"
    assert VISA_SETTINGS["timeout_s"] >= 5


def test_is_a_temperature_scanner(scanner):
    assert isinstance(scanner, TemperatureScanner)


def test_identity_of_both_models(sim, scanner):
    assert "DAQ970A" in scanner.identity() and scanner.detected_model == "DAQ970A"
    old = Keysight34970A(sim.serial("34970a", SERIAL_SETTINGS))
    assert old.identity() == "HEWLETT-PACKARD,34970A,0,13-2-2" and old.detected_model == "34970A"


def test_identity_refuses_another_instrument(sim):
    with pytest.raises(InstrumentError, match=r"HMP4040.*not a DAQ970A"):
        DAQ970A(sim.serial("hmp4040", SERIAL_SETTINGS)).identity()


def test_configure_and_read_three_thermocouples(sim, scanner):
    wire = sim.capture("daq970a")
    scanner.configure()
    assert bytes(wire) == CONFIGURE_BYTES
    emulator = sim.emulator("daq970a")
    assert emulator.scan_list == [101, 102, 103]
    assert all(c.tc_type == "K" and c.open_check and c.reference_junction == "INT" for c in emulator.channels.values())
    wire.clear()
    start = sim.clock.now()
    temperatures = scanner.read_temperatures_c()
    assert bytes(wire) == b"READ?\n"
    assert list(temperatures) == ["coil", "target", "ambient"]
    assert all(abs(t - 22.0) < 0.2 for t in temperatures.values())
    assert sim.clock.now() - start == pytest.approx(0.3)  # the scan takes simulated time


def test_readings_are_nr3(sim, scanner):
    scanner.configure()
    reply = scanner.transport.query("READ?")
    assert all(len(field) == 15 and field[0] == "+" and field[-4] == "E" for field in reply.split(","))


def test_channels_named_out_of_order_are_mapped_by_number(make_lab):
    sim = make_lab(thermocouple_channels={105: "coil", 101: "target", 103: "ambient"})
    sim.lab.t_target_c = 80.0
    scanner = DAQ970A(sim.serial("daq970a", SERIAL_SETTINGS), channels={"coil": 105, "target": 101, "ambient": 103})
    wire = sim.capture("daq970a")
    scanner.configure()
    assert bytes(wire).startswith(b"CONF:TEMP TC,K,(@101,103,105)\n")
    temperatures = scanner.read_temperatures_c()
    assert temperatures["target"] == pytest.approx(80.0, abs=0.2)
    assert temperatures["coil"] == pytest.approx(22.0, abs=0.2)


def test_other_thermocouple_type(sim):
    scanner = DAQ970A(sim.serial("daq970a", SERIAL_SETTINGS), thermocouple_type="j")
    wire = sim.capture("daq970a")
    scanner.configure()
    assert bytes(wire).startswith(b"CONF:TEMP TC,J,(@101:103)\n")


def test_channel_list_format():
    assert channel_list([103, 101, 102]) == "(@101:103)"
    assert channel_list([101, 103]) == "(@101,103)"
    assert channel_list([120, 201]) == "(@120,201)"
    assert channel_list([107]) == "(@107)"


def test_open_thermocouple_is_an_error_naming_the_channel(sim, scanner):
    scanner.configure()
    sim.lab.faults.open_thermocouples.add(102)
    with pytest.raises(InstrumentError, match=r"channel 102 \('target'\): open thermocouple") as error:
        scanner.read_temperatures_c()
    assert "+9.90000000E+37" in error.value.reply


def test_open_input_without_the_check_reads_negative_overload_and_is_still_an_error(sim, scanner):
    scanner.configure()
    scanner.write("SENS:TEMP:TRAN:TC:CHEC OFF,(@103)")
    sim.lab.faults.open_thermocouples.add(103)
    with pytest.raises(InstrumentError, match=r"channel 103 \('ambient'\)") as error:
        scanner.read_temperatures_c()
    assert "-9.90000000E+37" in error.value.reply


@pytest.mark.parametrize("options, message", [
    ({"channels": {"coil": 100}}, "not a multiplexer channel"),
    ({"channels": {"coil": 121}}, "not a multiplexer channel"),
    ({"channels": {"coil": 401}}, "not a multiplexer channel"),
    ({"channels": {"coil": "101"}}, "not a channel number"),
    ({"channels": {"coil": 101, "target": 101}}, "already used by 'coil'"),
    ({"channels": {}}, "at least one channel"),
    ({"thermocouple_type": "X"}, "'X' is not one of B, E, J, K, N, R, S, T"),
])
def test_bad_settings_raise_before_anything_is_sent(sim, options, message):
    wire = sim.capture("daq970a")
    with pytest.raises(InvalidSettingError, match=message):
        DAQ970A(sim.serial("daq970a", SERIAL_SETTINGS), **options)
    assert bytes(wire) == b""


def test_instrument_refusal_surfaces_with_the_error_queue_text(sim):
    """Slot 2 is empty in the simulated unit: the driver accepts 201, the instrument refuses it."""
    scanner = DAQ970A(sim.serial("daq970a", SERIAL_SETTINGS), channels={"coil": 201})
    with pytest.raises(InstrumentError, match=r'CONF:TEMP TC,K,\(@201\).*-221,"Settings conflict"'):
        scanner.configure()
    assert scanner.error_queue() == []  # drained


def test_read_with_an_empty_scan_list_reports_the_queued_error(sim, scanner):
    scanner.configure()
    scanner.write("ROUT:SCAN (@)")
    assert scanner.transport.query("ROUT:SCAN?") == "#13(@)"
    with pytest.raises(InstrumentError, match=r"'READ\?'.*-221"):
        scanner.read_temperatures_c()


def test_scan_list_query_is_a_definite_length_block(sim, scanner):
    scanner.configure()
    assert scanner.transport.query("ROUT:SCAN?") == "#214(@101,102,103)"
    assert scanner.transport.query("rout:scan:size?") == "+3"


def test_unit_and_measure_commands(sim, scanner):
    scanner.configure()
    scanner.write("UNIT:TEMP K,(@102)")
    reply = scanner.transport.query("READ?").split(",")
    assert float(reply[1]) == pytest.approx(295.15, abs=0.2)
    reply = scanner.transport.query("MEASure:TEMPerature? TCouple,T,(@101)")
    assert float(reply) == pytest.approx(22.0, abs=0.2)
    assert sim.emulator("daq970a").scan_list == [101]


def test_through_pyvisa(sim):
    """pyvisa-py opens ASRL<url>::INSTR with pyserial's serial_for_url, so this is the full VISA stack."""
    link = VisaTransport("daq970a", "ASRL" + sim.url("daq970a") + "::INSTR", clock=sim.clock, **VISA_SETTINGS)
    scanner = DAQ970A(link)
    wire = sim.capture("daq970a")
    assert "DAQ970A" in scanner.identity()
    scanner.configure()
    temperatures = scanner.read_temperatures_c()
    assert bytes(wire) == b"*IDN?\n" + CONFIGURE_BYTES + b"READ?\n"
    assert all(abs(t - 22.0) < 0.2 for t in temperatures.values())
    link.close()


# -- every command the driver sends, byte for byte against literal replies (no simulator) --------------------
# [34970A-UG ch.5]: CONFigure:TEMPerature, UNIT:TEMPerature, ...RJUNction:TYPE, ...TCouple:CHECk, ROUTe:SCAN,
# READ?, SYSTem:ERRor? (+0,"No error" ends the queue); LF-terminated [dvg]; *IDN? [34970A-UG p.146].

def _scanner(pairs, **options):
    from ecds_lab.testing import expected_protocol

    return expected_protocol(DAQ970A, pairs, link_settings=VISA_SETTINGS, **options)


def test_protocol_identity_configure_and_read():
    configure = [(line + b"\n", None) for line in CONFIGURE_BYTES.split(b"\n")[:-2]]
    pairs = [(b"*IDN?\n", b"Keysight Technologies,DAQ970A,MY58000001,A.02.04-00.16-11.29-00.02-02-01\n"),
             *configure, (b"SYST:ERR?\n", b'+0,"No error"\n'),
             (b"READ?\n", b"+2.21234567E+01,+2.31234567E+01,+2.20000000E+01\n")]
    with _scanner(pairs) as scanner:
        scanner.identity()
        scanner.configure()
        assert scanner.read_temperatures_c() == {"coil": 22.1234567, "target": 23.1234567, "ambient": 22.0}


def test_protocol_a_queued_error_after_configure_is_raised_and_drained():
    configure = [(line + b"\n", None) for line in CONFIGURE_BYTES.split(b"\n")[:-2]]
    pairs = [*configure, (b"SYST:ERR?\n", b'-221,"Settings conflict"\n'), (b"SYST:ERR?\n", b'+0,"No error"\n')]
    with _scanner(pairs) as scanner, pytest.raises(InstrumentError, match="-221"):
        scanner.configure()


def test_protocol_a_read_that_times_out_asks_the_error_queue_why():
    pairs = [(b"READ?\n", None), (b"SYST:ERR?\n", b'-221,"Settings conflict"\n'), (b"SYST:ERR?\n", b'+0,"No error"\n')]
    with _scanner(pairs) as scanner, pytest.raises(InstrumentError, match=r"READ\?.*-221"):
        scanner.read_temperatures_c()
