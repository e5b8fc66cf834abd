"""The instrument table: every row resolves, and config, station and simulators all follow it."""

from __future__ import annotations

import pydantic
import pytest

from ecds_lab.config.station import ROLES, InstrumentConfig, StationConfig, VisaLink
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


def test_config_roles_and_registry_read_the_table():
    assert ROLES == {role: drivers_for_role(role) for role in ROLE_NAMES}
    assert ROLES["scanner"] == ("daq970a", "34970a")
    assert _emulator_class("34970a") is kind("34970a").emulator_class()
    with pytest.raises(KeyError, match="no simulated instrument 'hm9999'"):
        _emulator_class("hm9999")


def test_unknown_driver_names_the_allowed_ones():
    with pytest.raises(pydantic.ValidationError, match="unknown driver 'hm9999'; allowed: 'hm8118', 'grbl'"):
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
