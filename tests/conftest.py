"""Fixtures shared by the whole suite: a fresh simulated lab per test and links into it."""

from __future__ import annotations

import itertools
from typing import Any, Callable

import pytest

from ecds_lab.clock import SimulatedClock
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.simulators.registry import emulator, register_lab
from ecds_lab.transports.serial_link import SerialTransport

_lab_numbers = itertools.count()


class LabHandle:
    """A registered simulated lab with helpers to open real transports into it."""

    def __init__(self, config: LabConfig) -> None:
        self.name = f"test{next(_lab_numbers)}"
        self.clock = SimulatedClock()
        self.lab = register_lab(self.name, SimulatedLab(config, self.clock))

    def url(self, instrument: str) -> str:
        return f"ecdssim://{self.name}/{instrument}"

    def serial(self, instrument: str, settings: dict[str, Any], **overrides: Any) -> SerialTransport:
        """A pyserial link to a simulated instrument, with the driver's link settings."""
        options = {**settings, **overrides}
        return SerialTransport(instrument, self.url(instrument), clock=self.clock, **options)

    def emulator(self, instrument: str):  # noqa: ANN201
        return emulator(self.name, instrument)

    def capture(self, instrument: str) -> bytearray:
        """Start capturing the exact bytes the host sends to an instrument."""
        emu = self.emulator(instrument)
        emu.wire = bytearray()
        return emu.wire


@pytest.fixture
def make_lab() -> Callable[..., LabHandle]:
    """Build a simulated lab from LabConfig keyword arguments."""
    return lambda **config: LabHandle(LabConfig(**config))


@pytest.fixture
def sim(make_lab: Callable[..., LabHandle]) -> LabHandle:
    """The default simulated lab: the paper's prototype coil facing a copper plate."""
    return make_lab()


@pytest.fixture
def open_sim_station():
    """Open stations on simulated labs (through the real drivers and transports); closed at teardown."""
    from ecds_lab.config.station import SimulationConfig, StationConfig
    from ecds_lab.instruments import BridgeSettings
    from ecds_lab.station import open_station

    opened = []

    def build(*, averages: int = 1, **lab: Any):
        config = StationConfig(simulated=SimulationConfig(lab=LabConfig(**lab), pacing=False))
        station = open_station(config)
        opened.append(station)
        station.bridge.configure(BridgeSettings(function="L-R", circuit="series", voltage_v=1.5, speed="slow",
                                                averages=averages))
        station.scanner.configure()
        station.slide.home()
        return station

    yield build
    for station in opened:
        station.close()
