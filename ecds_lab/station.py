"""Open a station: drivers over their transports, for the real lab or the simulated one.

The simulated lab is reached through the same transports as hardware: pyserial's
``ecdssim://`` scheme for the serial instruments and pyvisa-py ``ASRLecdssim://...::INSTR``
resources for the VISA ones. Replay swaps only the transports (``transport_factory``).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ecds_lab import shipped
from ecds_lab.clock import Clock, SimulatedClock, WallClock
from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.references import station_path
from ecds_lab.config.station import InstrumentConfig, SerialLink, StationConfig, VisaLink
from ecds_lab.instruments.interfaces import HeaterSupply, LCRBridge, Positioner, TemperatureScanner
from ecds_lab.instruments.kinds import ROLE_NAMES, kind
from ecds_lab.transports.base import Transport
from ecds_lab.transports.serial_link import SerialTransport
from ecds_lab.transports.visa_link import VisaTransport

DEFAULT_STATION = shipped.station("simulated_lab.yaml")

TransportFactory = Callable[[str, InstrumentConfig, dict[str, Any], Clock], Transport]
_lab_numbers = itertools.count()


def driver_class(driver: str) -> Any:
    """The driver class of an instrument kind (imported on first use)."""
    return kind(driver).driver_class()


def link_settings(driver: str, link: SerialLink | VisaLink) -> dict[str, Any]:
    """The driver's documented link settings for this kind of link, with the station's overrides."""
    settings = kind(driver).link_settings(link.kind)
    if link.timeout_s is not None:
        settings["timeout_s"] = link.timeout_s
    if isinstance(link, SerialLink) and link.baudrate is not None:
        settings["baudrate"] = link.baudrate
    return settings


def simulated_link(driver: str, lab: str) -> SerialLink | VisaLink:
    """How the simulated station reaches an instrument whose YAML entry gives no link."""
    row = kind(driver)
    address = row.simulated_address(lab)
    return SerialLink(url=address) if row.simulated_link == "serial" else VisaLink(resource=address)


def open_transport(role: str, instrument: InstrumentConfig, settings: dict[str, Any], clock: Clock) -> Transport:
    """A pyserial or pyvisa link as the station describes it."""
    link = instrument.link
    if isinstance(link, SerialLink):
        return SerialTransport(role, link.url, clock=clock, **settings)
    assert isinstance(link, VisaLink)
    return VisaTransport(role, link.resource, backend=link.backend, clock=clock, **settings)


@dataclass
class Station:
    """The four instruments of one lab, their transports and the clock they share."""

    config: StationConfig
    clock: Clock
    bridge: LCRBridge
    slide: Positioner
    scanner: TemperatureScanner
    heater: HeaterSupply
    transports: dict[str, Transport]
    lab: Any = None
    yaml_text: str = ""
    identities: dict[str, str] = field(default_factory=dict)

    def identify(self) -> dict[str, str]:
        """Ask every instrument who it is (recorded in the run file)."""
        self.identities = {role: getattr(self, role).identity() for role in ROLE_NAMES}
        return self.identities

    def close(self) -> None:
        for transport in self.transports.values():
            transport.close()


def load_station_config(path: str | Path | None) -> tuple[StationConfig, str]:
    """The station YAML (a path or a shipped name; default: the simulated lab) validated, and its text."""
    path = station_path(path)
    return load_yaml_model(path, StationConfig), path.read_text()


def open_station(config: StationConfig, yaml_text: str = "", *, transport_factory: TransportFactory | None = None,
                 clock: Clock | None = None) -> Station:
    """Build drivers over transports; for a simulated station, create and register its lab first."""
    lab = None
    if clock is None:
        clock = SimulatedClock(real_time_factor=config.simulated.real_time_factor) if config.simulated else WallClock()
    instruments = {role: getattr(config, role) for role in ROLE_NAMES}
    if config.simulated is not None and transport_factory is None:
        from ecds_lab.simulators.lab import SimulatedLab
        from ecds_lab.simulators.registry import register_lab

        assert isinstance(clock, SimulatedClock)
        lab_name = f"lab{next(_lab_numbers)}"
        lab = register_lab(lab_name, SimulatedLab(config.simulated.lab, clock))
        if not config.simulated.pacing:  # the host keeps no pauses: no emulator may lose a command for it
            from ecds_lab.simulators.registry import emulator

            for instrument in instruments.values():
                emulator(lab_name, instrument.driver).paced_host = False
        instruments = {role: inst if inst.link is not None else
                       inst.model_copy(update={"link": simulated_link(inst.driver, lab_name)})
                       for role, inst in instruments.items()}
    factory = transport_factory or open_transport
    transports: dict[str, Transport] = {}
    drivers: dict[str, Any] = {}
    try:
        for role, instrument in instruments.items():
            settings = link_settings(instrument.driver, instrument.link) if instrument.link else {}
            if instrument.min_interval_s is not None:
                settings["min_interval_s"] = instrument.min_interval_s
            if config.simulated is not None and not config.simulated.pacing:
                settings["min_interval_s"] = 0.0
            transports[role] = factory(role, instrument, settings, clock)
            drivers[role] = driver_class(instrument.driver)(transports[role], **instrument.options)
    except Exception:
        for transport in transports.values():
            transport.close()
        raise
    return Station(config, clock, lab=lab, transports=transports, yaml_text=yaml_text or yaml.safe_dump(
        config.model_dump(mode="json")), **drivers)
