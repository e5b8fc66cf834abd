"""Vendor-independent interfaces of the lab's instruments (what the runner talks to)."""

from ecds_lab.instruments.interfaces import (
    BridgeReading,
    BridgeSettings,
    HeaterSupply,
    LCRBridge,
    Positioner,
    TemperatureScanner,
)

__all__ = ["BridgeReading", "BridgeSettings", "HeaterSupply", "LCRBridge", "Positioner", "TemperatureScanner"]
