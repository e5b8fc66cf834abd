"""The instrument table: every row resolves, and config, station and simulators all follow it."""

from __future__ import annotations

import pydantic
import pytest

from ecds_lab.config.station import InstrumentConfig, StationConfig, VisaLink
from ecds_lab.instruments.kinds import KINDS, ROLE_NAMES, drivers_for_role, kind
from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.registry import _emulator_class
from ecds_lab.station import link_settings, simulated_link


@pytest.mark.parametrize("name", list(KINDS))
def test_every_row_names_classes_and_settings_that_exist(name):
    row = kind(name)
    assert isinstance(row.driver_class(), type)
    emulator = row.emulator_class()
    assert issubclass(emulator, LineEmulator) and emulator.name == name
    assert row.roles and set(row.roles) <= set(ROLE_NAMES)
    assert row.simulated_link in row.links
    for link in row.links:
        settings = row.link_settings(link)
        assert {"write_termination", "read_termination", "timeout_s"} <= set(settings)
        assert ("baudrate" in settings) == (link == "serial")


def test_settings_are_copies():
    kind("hm8118").link_settings("serial")["baudrate"] = 1
    assert kind("hm8118").link_settings("serial")["baudrate"] == 9600


def test_simulated_addresses():
    assert kind("hm8118").simulated_address("lab3") == "ecdssim://lab3/hm8118"
    assert kind("34970a").simulated_address("lab3") == "ASRLecdssim://lab3/34970a::INSTR"
    assert simulated_link("hmp4040", "x") == VisaLink(resource="ASRLecdssim://x/hmp4040::INSTR")


def test_roles_and_registry_read_the_table():
    assert {role: drivers_for_role(role) for role in ROLE_NAMES} == {
        "bridge": ("hm8118",), "slide": ("grbl",), "scanner": ("daq970a", "34970a"), "heater": ("hmp4040",)}
    assert _emulator_class("34970a") is kind("34970a").emulator_class()
    with pytest.raises(KeyError, match="no simulated instrument 'hm9999'"):
        _emulator_class("hm9999")


def test_unknown_driver_names_the_allowed_ones():
    allowed = r"'hm8118' \(bridge\), 'grbl' \(slide\), 'daq970a' \(scanner\)"
    with pytest.raises(pydantic.ValidationError, match=rf"unknown driver 'hm9999'; allowed: {allowed}"):
        InstrumentConfig(driver="hm9999")


def test_a_link_kind_the_driver_has_no_settings_for_is_refused():
    with pytest.raises(pydantic.ValidationError, match="driver 'hm8118' has no visa link; allowed: serial"):
        InstrumentConfig(driver="hm8118", link={"kind": "visa", "resource": "TCPIP0::192.0.2.1::5025::SOCKET"})


def test_station_overrides_win_over_the_drivers_settings():
    link = InstrumentConfig(driver="daq970a", link={"kind": "serial", "url": "/dev/ttyS0", "baudrate": 19200,
                                                    "timeout_s": 9.0}).link
    assert link is not None
    settings = link_settings("daq970a", link)
    assert settings["baudrate"] == 19200 and settings["timeout_s"] == 9.0 and settings["xonxoff"] is True


def test_wrong_role_is_refused_with_the_drivers_that_fit():
    with pytest.raises(pydantic.ValidationError, match="'grbl' cannot serve as scanner; allowed: daq970a, 34970a"):
        StationConfig(simulated={}, scanner={"driver": "grbl"})


def test_one_new_row_is_all_a_new_instrument_needs(monkeypatch):
    """A row naming existing classes under a new name: config accepts it, the station reaches it by ecdssim://."""
    from ecds_lab.config.station import SimulationConfig
    from ecds_lab.instruments.kinds import InstrumentKind
    from ecds_lab.station import open_station

    original = kind("hm8118")
    monkeypatch.setitem(KINDS, "hm8118-bench", InstrumentKind(
        "hm8118-bench", original.driver, original.emulator, ("bridge",), original.links, "serial"))
    config = StationConfig(simulated=SimulationConfig(pacing=False), bridge={"driver": "hm8118-bench"})
    station = open_station(config)
    try:
        assert station.transports["bridge"].url.endswith("/hm8118-bench")
        assert "HM8118" in station.bridge.identity()
    finally:
        station.close()
