"""Typed interfaces for the four kinds of instrument, independent of vendor.

SI units throughout (m, Hz, V, A, H, Ohm); temperatures in degrees Celsius with
``_c`` in the name. Drivers implement these; the runner and tests use only these.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

Function = Literal["auto", "L-Q", "L-R", "C-D", "C-R", "R-Q", "Z-theta", "Y-theta", "R-X", "G-B", "N-theta", "M"]
Circuit = Literal["series", "parallel", "auto"]
Speed = Literal["fast", "medium", "slow"]


@dataclass(frozen=True)
class BridgeSettings:
    """How the bridge measures: the paper uses L-R series, 1.5 V, slow."""

    function: Function = "L-R"
    circuit: Circuit = "series"
    voltage_v: float = 1.5
    speed: Speed = "slow"
    averages: int = 1


@dataclass(frozen=True)
class BridgeReading:
    """One measurement: main and secondary value of the active function (L-R: H and Ohm)."""

    main: float
    secondary: float
    frequency_hz: float


@runtime_checkable
class LCRBridge(Protocol):
    """An LCR bridge with discrete test frequencies and a manual trigger."""

    def identity(self) -> str: ...

    def configure(self, settings: BridgeSettings) -> None: ...

    def set_frequency(self, frequency_hz: float) -> None: ...

    def measure(self) -> BridgeReading: ...

    def open_compensation(self, all_frequencies: bool = False) -> None: ...

    def short_compensation(self, all_frequencies: bool = False) -> None: ...


@runtime_checkable
class Positioner(Protocol):
    """A linear stage that sets the coil-target distance x (m)."""

    min_position_m: float
    max_position_m: float

    def identity(self) -> str: ...

    def home(self) -> None: ...

    def move_to(self, position_m: float, speed_m_per_s: float | None = None) -> int:
        """Move, wait until it stands still; returns the direction of the final approach (+1/-1)."""
        ...

    def position_m(self) -> float: ...

    def stop(self) -> None: ...


@runtime_checkable
class TemperatureScanner(Protocol):
    """A thermocouple scanner whose channels have names ('coil', 'target', 'ambient')."""

    def identity(self) -> str: ...

    def configure(self) -> None: ...

    def read_temperatures_c(self) -> dict[str, float]: ...


@runtime_checkable
class HeaterSupply(Protocol):
    """A DC supply output driving a heater; outputs are numbered from 1."""

    max_voltage_v: float
    max_current_a: float

    def identity(self) -> str: ...

    def set_output(self, output: int, voltage_v: float, current_limit_a: float) -> None: ...

    def enable(self, output: int, on: bool) -> None: ...

    def read_back(self, output: int) -> tuple[float, float]:
        """Measured (voltage V, current A) at an output."""
        ...

    def all_off(self) -> None: ...
