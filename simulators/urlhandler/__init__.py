"""pyserial protocol handlers of the simulated lab (``ecdssim://``), registered by the simulators themselves."""

from __future__ import annotations

import serial


def register_scheme() -> None:
    """Make pyserial (and pyvisa-py's ASRL resources, which open through it) resolve ``ecdssim://`` here."""
    if __name__ not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(__name__)
