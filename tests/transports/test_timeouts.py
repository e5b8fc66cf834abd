"""Per-read timeouts: a read waits for the link's timeout, or for the one the driver gives that read."""

from __future__ import annotations

import pytest

from ecds_lab.drivers.daq970a import VISA_SETTINGS
from ecds_lab.drivers.hm8118 import HM8118, SERIAL_SETTINGS
from ecds_lab.errors import TransportTimeout
from ecds_lab.instruments import BridgeSettings
from ecds_lab.transports.visa_link import VisaTransport


@pytest.fixture
def silent(sim):
    """The simulated lab with the bridge and the scanner not answering."""
    sim.lab.faults.silent_instruments.update({"hm8118", "daq970a"})
    return sim


def _waited(sim, link, **read):
    start = sim.clock.now()
    with pytest.raises(TransportTimeout) as error:
        link.query("*IDN?", **read)
    return sim.clock.now() - start, str(error.value)


def test_a_serial_read_waits_for_the_link_timeout_or_the_one_given(silent):
    link = silent.serial("hm8118", SERIAL_SETTINGS, min_interval_s=0.0)
    waited, message = _waited(silent, link)
    assert waited == pytest.approx(SERIAL_SETTINGS["timeout_s"], abs=0.01) and "3 s" in message
    waited, message = _waited(silent, link, timeout_s=7.5)
    assert waited == pytest.approx(7.5, abs=0.01) and "7.5 s" in message
    waited, _ = _waited(silent, link)  # the next read is back to the link's own timeout
    assert waited == pytest.approx(SERIAL_SETTINGS["timeout_s"], abs=0.01)
    assert [e.text for e in link.transcript if e.kind == "error"] == ["timeout"] * 3


def test_a_visa_read_waits_for_the_timeout_given(silent):
    link = VisaTransport("daq970a", "ASRL" + silent.url("daq970a") + "::INSTR", clock=silent.clock, **VISA_SETTINGS)
    waited, _ = _waited(silent, link, timeout_s=9.0)
    assert waited == pytest.approx(9.0, abs=0.01)
    waited, _ = _waited(silent, link)
    assert waited == pytest.approx(VISA_SETTINGS["timeout_s"], abs=0.01)


def test_an_averaged_reading_longer_than_the_link_timeout_is_waited_for(sim):
    bridge = HM8118(sim.serial("hm8118", SERIAL_SETTINGS))
    bridge.configure(BridgeSettings(speed="slow", averages=10))  # 10 x 0.6 s, twice the 3 s link timeout
    start = sim.clock.now()
    reading = bridge.measure()
    assert sim.clock.now() - start >= 6.0 and reading.main > 0
