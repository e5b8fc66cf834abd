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
