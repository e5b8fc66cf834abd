"""The emulators hold their own tables, from the manuals: a wrong code in a driver is refused, not mirrored.

Each test plays a driver bug (a table entry the manual does not have) through the real
transport and checks that the emulator refuses it the way the instrument would.
"""

from __future__ import annotations

import pytest

from ecds_lab.drivers import daq970a as daq_driver
from ecds_lab.drivers.daq970a import DAQ970A
from ecds_lab.drivers.hm8118 import FREQUENCIES_HZ, HM8118, SERIAL_SETTINGS
from ecds_lab.drivers.instrument import Control, one_of
from ecds_lab.errors import InstrumentError
from ecds_lab.simulators import daq970a as daq_emulator
from ecds_lab.simulators import hm8118 as hm_emulator


class MistypedHM8118(HM8118):
    """An HM8118 driver whose frequency table gained 21 Hz, a value the bridge does not have."""

    frequency_hz = Control("FREQ?", "FREQ {:.0f}", "Test frequency with a mistyped table.",
                           validator=one_of((*FREQUENCIES_HZ, 21), " Hz"))


def test_hm8118_frequencies_are_the_manuals_steps():
    assert len(hm_emulator.FREQUENCIES_HZ) == 69
    assert min(hm_emulator.FREQUENCIES_HZ) == 20 and max(hm_emulator.FREQUENCIES_HZ) == 200_000
    assert {24, 36, 72, 1200, 4500, 180_000} <= hm_emulator.FREQUENCIES_HZ
    assert not {21, 35, 110, 210_000} & hm_emulator.FREQUENCIES_HZ


def test_driver_and_emulator_tables_agree_though_written_apart():
    assert set(FREQUENCIES_HZ) == hm_emulator.FREQUENCIES_HZ
    assert set(daq_driver.TC_TYPES) == daq_emulator.THERMOCOUPLE_TYPES


@pytest.mark.parametrize("command, reply", [
    (b"FREQ 21\r", b"ERROR\r"), (b"VOLT 1.6\r", b"ERROR\r"), (b"VOLT 0.04\r", b"ERROR\r"),
    (b"PMOD 12\r", b"ERROR\r"), (b"RATE 3\r", b"ERROR\r"), (b"NAVG 100\r", b"ERROR\r"),
    (b"FREQ 24\rFREQ?\r", b"24\r"), (b"VOLT 0.05\rVOLT?\r", b"0.050\r"),
])
def test_hm8118_emulator_refuses_what_the_manual_does_not_list(sim, command, reply):
    link = sim.serial("hm8118", SERIAL_SETTINGS, min_interval_s=0.0)
    for line in command.split(b"\r")[:-1]:  # one line at a time, paced as the bridge needs
        link.port.write(line + b"\r")
        sim.clock.sleep(SERIAL_SETTINGS["min_interval_s"])
    assert link.port.read(len(reply)) == reply


def test_a_frequency_mistyped_in_the_driver_is_refused_by_the_emulator(sim):
    bridge = MistypedHM8118(sim.serial("hm8118", SERIAL_SETTINGS))
    with pytest.raises(InstrumentError, match=r"FREQ 21.*ERROR"):
        bridge.set_frequency(21)


def test_a_thermocouple_type_the_manual_lacks_is_refused_by_the_emulator(sim, monkeypatch):
    monkeypatch.setattr(daq_driver, "TC_TYPES", (*daq_driver.TC_TYPES, "L"))
    scanner = DAQ970A(sim.serial("daq970a", daq_driver.SERIAL_SETTINGS), thermocouple_type="L")
    with pytest.raises(InstrumentError, match=r"CONF:TEMP TC,L.*-224"):
        scanner.configure()
