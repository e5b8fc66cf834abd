"""HM8118 driver against its emulator through the real pyserial path: exact bytes, errors, validation."""

from __future__ import annotations

import pytest

from ecds_lab.drivers.hm8118 import FREQUENCIES_HZ, HM8118, SERIAL_SETTINGS
from ecds_lab.errors import InstrumentError, InvalidSettingError
from ecds_lab.instruments import BridgeSettings


@pytest.fixture
def bridge(sim):
    return HM8118(sim.serial("hm8118", SERIAL_SETTINGS))


def test_link_settings_follow_the_manual():
    assert SERIAL_SETTINGS["baudrate"] == 9600
    assert SERIAL_SETTINGS["write_termination"] == "\r"
    assert 0.15 <= SERIAL_SETTINGS["min_interval_s"] <= 0.2
    assert len(FREQUENCIES_HZ) == 69 and FREQUENCIES_HZ[0] == 20 and FREQUENCIES_HZ[-1] == 200_000


def test_identity(bridge):
    assert "HM8118" in bridge.identity()


def test_configure_as_the_paper_sends_exact_bytes(sim, bridge):
    wire = sim.capture("hm8118")
    bridge.configure(BridgeSettings(function="L-R", circuit="series", voltage_v=1.5, speed="slow"))
    bridge.set_frequency(15000)
    bridge.set_frequency(500)
    assert bytes(wire) == (
        b"PMOD 2\rPMOD?\rCIRC 0\rCIRC?\rVOLT 1.500\rVOLT?\rRATE 2\rRATE?\rAVGM 0\rAVGM?\r"
        b"MMOD 1\rMMOD?\rFREQ 15000\rFREQ?\rFREQ 500\rFREQ?\r"
    )
    assert bridge.speed == "slow" and bridge.circuit == "series" and bridge.voltage_v == 1.5


def test_averaging_sends_count(sim, bridge):
    wire = sim.capture("hm8118")
    bridge.configure(BridgeSettings(averages=8))
    assert b"AVGM 1\rAVGM?\rNAVG 8\rNAVG?\r" in bytes(wire)


def test_measure_triggers_waits_and_reads(make_lab):
    sim = make_lab(slide_origin_mm=50.0)
    bridge = HM8118(sim.serial("hm8118", SERIAL_SETTINGS))
    bridge.configure(BridgeSettings())
    bridge.set_frequency(15000)
    wire = sim.capture("hm8118")
    start = sim.clock.now()
    reading = bridge.measure()
    assert bytes(wire) == b"*TRG\r*WAI\rXALL?\r"
    assert 40e-3 < reading.main < 60e-3  # series inductance in H
    assert 30 < reading.secondary < 1000  # series resistance in Ohm
    assert reading.frequency_hz == 15000
    assert sim.clock.now() - start >= 0.6  # a slow measurement takes simulated time


def test_pacing_between_commands_uses_the_shared_clock(sim):
    bridge = HM8118(sim.serial("hm8118", SERIAL_SETTINGS))
    start = sim.clock.now()
    bridge.identity()
    bridge.identity()
    assert sim.clock.now() - start >= SERIAL_SETTINGS["min_interval_s"]


@pytest.mark.parametrize("setting, value, message", [
    ("frequency_hz", 15001, "nearest allowed is 15000"),
    ("voltage_v", 2.0, "outside the allowed 0.05..1.5"),
    ("voltage_v", 0.01, "outside the allowed 0.05..1.5"),
    ("speed", "slowest", "'slowest' is not one of"),
    ("averages", 100, "outside the allowed 2..99"),
])
def test_bad_input_raises_before_anything_is_sent(sim, bridge, setting, value, message):
    wire = sim.capture("hm8118")
    with pytest.raises(InvalidSettingError, match=message):
        setattr(bridge, setting, value)
    assert bytes(wire) == b""


def test_invalid_configuration_sends_nothing(sim, bridge):
    wire = sim.capture("hm8118")
    with pytest.raises(InvalidSettingError):
        bridge.configure(BridgeSettings(voltage_v=3.0))
    assert bytes(wire) == b""


def test_error_reply_names_the_command(sim, bridge):
    sim.lab.faults.bridge_error_commands.add("FREQ")
    with pytest.raises(InstrumentError, match=r"'FREQ 1000'.*ERROR"):
        bridge.frequency_hz = 1000


def test_reading_in_auto_function_is_an_error(bridge):
    bridge.function = "auto"
    bridge.trigger_mode = "manual"
    with pytest.raises(InstrumentError, match="XALL"):
        bridge.measure()


def test_open_and_short_compensation(sim, bridge):
    wire = sim.capture("hm8118")
    start = sim.clock.now()
    bridge.open_compensation(all_frequencies=True)
    bridge.short_compensation()
    assert bytes(wire) == b"CALL 1\rCROP\rCALL 0\rCRSH\r"
    assert sim.clock.now() - start > 60  # 69 frequencies take minutes


def test_failed_compensation_is_reported(sim, bridge):
    sim.lab.faults.bridge_error_commands.add("CROP")
    with pytest.raises(InstrumentError, match="compensation failed"):
        bridge.open_compensation()


def test_silent_bridge_times_out(sim, bridge):
    from ecds_lab.errors import TransportTimeout

    sim.lab.faults.silent_instruments.add("hm8118")
    with pytest.raises(TransportTimeout, match="no reply"):
        bridge.identity()


# -- every command the driver sends, byte for byte against literal bridge replies (no simulator) --------------
# [M32] ch.10: CR-terminated four-letter mnemonics, set commands answer nothing, queries one CR-terminated line;
# [M23] "Befehlsliste": ERROR for a refused command; [KAK]: CROP/CRSH answer 0 or -1.

def _bridge(pairs):
    from ecds_lab.testing import expected_protocol

    return expected_protocol(HM8118, pairs, link_settings=SERIAL_SETTINGS)


def test_protocol_identity_and_reset():
    with _bridge([(b"*IDN?\r", b"HAMEG Instruments, HM8118,013206727,1.57\r"), (b"*RST\r", None)]) as bridge:
        assert bridge.identity() == "HAMEG Instruments, HM8118,013206727,1.57"
        bridge.reset()


def test_protocol_configure_reads_every_setting_back():
    pairs = [
        (b"PMOD 2\r", None), (b"PMOD?\r", b"2\r"), (b"CIRC 0\r", None), (b"CIRC?\r", b"0\r"),
        (b"VOLT 1.500\r", None), (b"VOLT?\r", b"1.500\r"), (b"RATE 2\r", None), (b"RATE?\r", b"2\r"),
        (b"AVGM 1\r", None), (b"AVGM?\r", b"1\r"), (b"NAVG 8\r", None), (b"NAVG?\r", b"8\r"),
        (b"MMOD 1\r", None), (b"MMOD?\r", b"1\r"), (b"FREQ 15000\r", None), (b"FREQ?\r", b"15000\r"),
    ]
    with _bridge(pairs) as bridge:
        bridge.configure(BridgeSettings(function="L-R", circuit="series", voltage_v=1.5, speed="slow", averages=8))
        bridge.set_frequency(15000)
        bridge.set_frequency(15000)  # unchanged: nothing sent


def test_protocol_a_refused_setting_is_named():
    with _bridge([(b"FREQ 1000\r", None), (b"FREQ?\r", b"ERROR\r")]) as bridge, \
            pytest.raises(InstrumentError, match=r"'FREQ 1000'.*ERROR"):
        bridge.frequency_hz = 1000


def test_protocol_measure_reads_the_frequency_once_then_triggers_waits_and_reads_all():
    pairs = [(b"FREQ?\r", b"1000\r"), (b"*TRG\r", None), (b"*WAI\r", None),
             (b"XALL?\r", b"4.93120E-02,1.23450E+02,0\r")]
    with _bridge(pairs) as bridge:
        reading = bridge.measure()
    assert (reading.main, reading.secondary, reading.frequency_hz) == (4.9312e-2, 123.45, 1000.0)


def test_protocol_compensation_open_at_all_frequencies_and_short_here():
    pairs = [(b"CALL 1\r", None), (b"CROP\r", b"0\r"), (b"CALL 0\r", None), (b"CRSH\r", b"-1\r")]
    with _bridge(pairs) as bridge:
        bridge.open_compensation(all_frequencies=True)
        with pytest.raises(InstrumentError, match="compensation failed"):
            bridge.short_compensation()


def test_a_pacing_regression_in_the_driver_shows_up(sim):
    """The bridge loses a command sent while it still takes in the previous one [M32: no parallel processing]."""
    from ecds_lab.errors import TransportTimeout

    bridge = HM8118(sim.serial("hm8118", SERIAL_SETTINGS, min_interval_s=0.05))
    with pytest.raises(TransportTimeout):
        bridge.frequency_hz = 1000  # FREQ? comes 50 ms after FREQ 1000: lost, no reply
    assert sim.emulator("hm8118").lost_lines == ["FREQ?"]


def test_a_simulated_station_without_pacing_loses_nothing():
    from ecds_lab.config.station import SimulationConfig, StationConfig
    from ecds_lab.station import open_station

    station = open_station(StationConfig(simulated=SimulationConfig(pacing=False)))
    try:
        assert station.bridge.transport.min_interval_s == 0.0
        station.bridge.configure(BridgeSettings())
        assert station.bridge.identity().startswith("HAMEG")
    finally:
        station.close()
