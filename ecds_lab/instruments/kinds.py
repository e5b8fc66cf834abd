"""The one table of instrument kinds: driver, emulator, roles, link settings, simulated address.

Config (which driver may serve which role), the station (which class to build, which link
settings to use, how the simulated lab is reached) and the simulator registry (which emulator
answers ``ecdssim://LAB/NAME``) all read this table. Classes and settings are named as lazy
``"module:attribute"`` strings, so this bottom layer imports neither drivers nor simulators.
Adding an instrument is one driver module, one emulator module and one row here.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Literal

Role = Literal["bridge", "slide", "scanner", "heater"]
LinkKind = Literal["serial", "visa"]

#: The four places an instrument can take in a station, in the order they are opened.
ROLE_NAMES: tuple[Role, ...] = ("bridge", "slide", "scanner", "heater")


@dataclass(frozen=True)
class InstrumentKind:
    """One kind of instrument, as station YAMLs name it (``driver: hm8118``) and ``ecdssim://`` URLs do."""

    name: str
    driver: str
    emulator: str
    roles: tuple[Role, ...]
    #: Link kind -> ``"module:attribute"`` of the driver's documented settings for that link.
    links: dict[LinkKind, str]
    #: How the simulated station reaches the emulator when the YAML gives no link.
    simulated_link: LinkKind

    def simulated_address(self, lab: str) -> str:
        """``ecdssim://LAB/NAME`` for a serial link, ``ASRLecdssim://LAB/NAME::INSTR`` for VISA."""
        url = f"ecdssim://{lab}/{self.name}"
        return url if self.simulated_link == "serial" else f"ASRL{url}::INSTR"

    def driver_class(self) -> Any:
        return load(self.driver)

    def emulator_class(self) -> Any:
        return load(self.emulator)

    def link_settings(self, link: LinkKind) -> dict[str, Any]:
        """A copy of the driver's documented settings for this kind of link."""
        if link not in self.links:
            raise KeyError(f"driver {self.name!r} has no {link} link; allowed: {', '.join(self.links)}")
        return dict(load(self.links[link]))


def load(reference: str) -> Any:
    """The object a ``"module:attribute"`` string names, importing the module on first use."""
    module, _, attribute = reference.partition(":")
    return getattr(importlib.import_module(module), attribute)


def _row(name: str, driver: str, emulator: str, roles: tuple[Role, ...], links: tuple[LinkKind, ...],
         simulated_link: LinkKind) -> InstrumentKind:
    """A row whose settings are the driver module's ``SERIAL_SETTINGS`` / ``VISA_SETTINGS``."""
    module = driver.partition(":")[0]
    settings = {link: f"{module}:{link.upper()}_SETTINGS" for link in links}
    return InstrumentKind(name, driver, emulator, roles, settings, simulated_link)


_D, _S = "ecds_lab.drivers", "ecds_lab.simulators"
KINDS: dict[str, InstrumentKind] = {kind.name: kind for kind in (
    _row("hm8118", f"{_D}.hm8118:HM8118", f"{_S}.hm8118:HM8118Emulator", ("bridge",), ("serial",), "serial"),
    _row("grbl", f"{_D}.grbl:Grbl", f"{_S}.grbl:GrblEmulator", ("slide",), ("serial",), "serial"),
    _row("daq970a", f"{_D}.daq970a:DAQ970A", f"{_S}.daq970a:DAQ970AEmulator", ("scanner",),
         ("serial", "visa"), "visa"),
    _row("34970a", f"{_D}.daq970a:Keysight34970A", f"{_S}.daq970a:Keysight34970AEmulator", ("scanner",),
         ("serial", "visa"), "visa"),
    _row("hmp4040", f"{_D}.hmp:HMP4040", f"{_S}.hmp:HMPEmulator", ("heater",), ("serial", "visa"), "visa"),
)}


def kind(name: str) -> InstrumentKind:
    """The row for a driver name; an unknown name raises KeyError listing the known ones."""
    if name not in KINDS:
        raise KeyError(f"no instrument kind {name!r}; known: {', '.join(KINDS)}")
    return KINDS[name]


def drivers_for_role(role: str) -> tuple[str, ...]:
    """The driver names that can serve ``role``, in table order."""
    return tuple(name for name, row in KINDS.items() if role in row.roles)
