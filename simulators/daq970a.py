"""DAQ970A / 34970A emulator: thermocouple channels scanned from the simulated lab's temperatures.

Written from the manuals, not from the driver (its tables are the emulator's own):
  [34970A-UG]   Agilent/HP 34970A User's Guide: ch.4 "To Build a Scan List" and "Rules for Using
                a Channel List", ch.5 CONFigure / ROUTe:SCAN (p.228), SYSTem:ERRor? (p.268)
  [34980A-help] 34980A online help (the same SCPI tree): CONFigure:TEMPerature, UNIT:TEMPerature,
                [SENSe:]TEMPerature:TRANsducer:TCouple:RJUNction:TYPE
  [dvg]         Dennis-van-Gils/python-dvg-devices, Keysight_3497xA_protocol_SCPI.py (*OPC? reply)
Speaks ``CONF:TEMP``, ``MEAS:TEMP?``, ``UNIT:TEMP``, ``SENS:TEMP:TRAN:TC:RJUN:TYPE``,
``SENS:TEMP:TRAN:TC:CHEC``, ``ROUT:SCAN``, ``ROUT:SCAN?`` (definite-length block
``#214(@101,102,103)``, empty ``#13(@)``), ``ROUT:SCAN:SIZE?``, ``READ?``, ``ABOR``.
CONF/MEAS redefine the scan list and reset the channels' settings [34970A-UG ch.4 "To Build a
Scan List"]. Which channel sees which lab temperature is
``LabConfig.thermocouple_channels``; other channels have nothing wired, i.e. an open input.

Readings are NR3 with 8 decimals (``+2.21234567E+01``), comma-separated in scan order; the
overload value prints the same way (``+9.90000000E+37``).

Assumptions, not from a manual:
  - one 20-channel multiplexer in slot 1, slots 2 and 3 empty; a channel in an empty slot
    is refused with -221 "Settings conflict";
  - the open-TC check is off after CONF; an open input reads +9.9E+37 with the check on and
    -9.9E+37 with it off (a public 34970A script saw "very large negative numbers" on open
    channels with no check; the exact values are unconfirmed);
  - a scan takes 0.1 s per channel (research estimate 0.1-0.5 s for three channels);
  - READ? with an empty scan list is refused with -221 "Settings conflict" and, as SCPI
    requires of a query that did not execute, sends no reply (the host's read times out);
  - a channel in the scan list but never configured reads as DC volts with nothing on it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import ClassVar

from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.simulators.scpi import SCPIEmulator, SCPIError

#: ``CONF:TEMP`` transducer names for a thermocouple (long and short form) [34980A-help CONFigure:TEMPerature].
THERMOCOUPLE_TRANSDUCERS = frozenset({"TC", "TCOUPLE"})
#: Thermocouple types the DMM linearises: ``{B|E|J|K|N|R|S|T}`` [34980A-help CONFigure:TEMPerature].
THERMOCOUPLE_TYPES = frozenset("BEJKNRST")
#: ``UNIT:TEMP {C|F|K}`` [34980A-help UNIT:TEMPerature].
UNITS = ("C", "F", "K")
#: ``RJUN:TYPE {INTernal|EXTernal|FIXed}``, long and short forms [34980A-help].
_REFERENCE_JUNCTIONS = {"INT": "INT", "INTERNAL": "INT", "EXT": "EXT", "EXTERNAL": "EXT", "FIX": "FIX", "FIXED": "FIX"}
#: Channel numbers are slot * 100 + channel: slots 1-3 [34970A-UG ch.4 "Rules for Using a Channel List"],
#: 20 channels on the 34901A multiplexer.
MAINFRAME_SLOTS: tuple[int, ...] = (1, 2, 3)
MULTIPLEXER_CHANNELS = 20
#: Modules fitted: slot 1 only (assumption, see above).
INSTALLED_SLOTS: tuple[int, ...] = (1,)
SCAN_TIME_PER_CHANNEL_S = 0.1
OVERLOAD = 9.9e37


@dataclass
class ThermocoupleChannel:
    """What a channel was configured for (the *RST state after CONF, then the changes sent)."""

    tc_type: str
    unit: str = "C"
    reference_junction: str = "INT"
    open_check: bool = False


class DAQ970AEmulator(SCPIEmulator):
    """A DAQ970A with a multiplexer in slot 1, measuring the lab's thermocouples."""

    name = "daq970a"
    identity = "Keysight Technologies,DAQ970A,MY58000001,A.02.04-00.16-11.29-00.02-02-01"
    opc_reply = "+1"  # [dvg]
    commands: ClassVar[dict[str, str]] = {
        "CONFigure:TEMPerature": "configure",
        "MEASure:TEMPerature?": "measure",
        "UNIT:TEMPerature": "set_unit",
        "[SENSe:]TEMPerature:TRANsducer:TCouple:RJUNction:TYPE": "set_reference_junction",
        "[SENSe:]TEMPerature:TRANsducer:TCouple:CHECk": "set_open_check",
        "ROUTe:SCAN": "set_scan",
        "ROUTe:SCAN?": "scan",
        "ROUTe:SCAN:SIZE?": "scan_size",
        "READ?": "read",
        "ABORt": "_nothing",
    }

    def __init__(self, lab: SimulatedLab) -> None:
        super().__init__(lab)
        self.reset()

    def reset(self) -> None:
        self.channels: dict[int, ThermocoupleChannel] = {}
        self.scan_list: list[int] = []

    # -- channel lists ------------------------------------------------------------------------
    @staticmethod
    def _valid(channel: int) -> bool:
        return channel // 100 in MAINFRAME_SLOTS and 1 <= channel % 100 <= MULTIPLEXER_CHANNELS

    def channel_list(self, text: str) -> list[int]:
        """``(@101:103,105)`` -> [101, 102, 103, 105]; range ends must be valid, invalid channels inside are skipped."""
        match = re.fullmatch(r"\(@\s*([\d\s:,]*)\)", text.strip())
        if match is None:
            raise SCPIError(-102)
        channels: set[int] = set()
        for item in filter(None, (part.strip() for part in match.group(1).split(","))):
            ends = [int(end) for end in item.split(":")] if re.fullmatch(r"\d+(\s*:\s*\d+)?", item) else []
            if not ends or not all(self._valid(end) for end in ends):
                raise SCPIError(-222)
            channels.update(c for c in range(min(ends), max(ends) + 1) if self._valid(c))
        if any(c // 100 not in INSTALLED_SLOTS for c in channels):
            raise SCPIError(-221)
        return sorted(channels)

    def _targets(self, parameters: list[str]) -> list[ThermocoupleChannel]:
        """The thermocouple channels a command addresses: its optional channel list, else the scan list."""
        numbers = self.channel_list(parameters[1]) if len(parameters) > 1 else self.scan_list
        if any(n not in self.channels for n in numbers):
            raise SCPIError(-221)
        return [self.channels[n] for n in numbers]

    # -- configuration ------------------------------------------------------------------------
    def configure(self, argument: str) -> None:
        """``CONF:TEMP TC,<type>[,...],(@list)``: the scan_list parameter is never optional [34970A-UG ch.5]."""
        parameters = self.parameters(argument)
        if len(parameters) < 3 or not parameters[-1].startswith("("):
            raise SCPIError(-109)
        channels = self.channel_list(parameters[-1])
        transducer, tc_type = parameters[0].upper(), parameters[1].upper()
        if transducer not in THERMOCOUPLE_TRANSDUCERS or tc_type not in THERMOCOUPLE_TYPES:
            raise SCPIError(-224)
        for number in channels:
            self.channels[number] = ThermocoupleChannel(tc_type)
        self.scan_list = channels

    def measure(self, argument: str) -> str:
        self.configure(argument)
        return self.read("")

    def set_unit(self, argument: str) -> None:
        parameters = self.parameters(argument)
        unit = parameters[0].upper() if parameters else ""
        if unit not in UNITS:
            raise SCPIError(-109 if not unit else -224)
        for channel in self._targets(parameters):
            channel.unit = unit

    def set_reference_junction(self, argument: str) -> None:
        parameters = self.parameters(argument)
        if not parameters:
            raise SCPIError(-109)
        if parameters[0].upper() not in _REFERENCE_JUNCTIONS:
            raise SCPIError(-224)
        for channel in self._targets(parameters):
            channel.reference_junction = _REFERENCE_JUNCTIONS[parameters[0].upper()]

    def set_open_check(self, argument: str) -> None:
        parameters = self.parameters(argument)
        on = self.boolean(parameters[0] if parameters else "")
        for channel in self._targets(parameters):
            channel.open_check = on

    def set_scan(self, argument: str) -> None:
        """``ROUT:SCAN (@list)``; ``(@)`` empties the scan list [34970A-UG ch.5 p.228]."""
        if not argument:
            raise SCPIError(-109)
        self.scan_list = self.channel_list(argument)

    def scan(self, _: str) -> str:
        body = "(@" + ",".join(str(c) for c in self.scan_list) + ")"
        return f"#{len(str(len(body)))}{len(body)}{body}"

    def scan_size(self, _: str) -> str:
        return f"{len(self.scan_list):+d}"

    # -- scanning -----------------------------------------------------------------------------
    def read(self, _: str) -> str:
        """One sweep of the scan list; the reply is ready when the sweep is done."""
        if not self.scan_list:
            raise SCPIError(-221)
        readings = ",".join(f"{self._reading(channel):+.8E}" for channel in self.scan_list)
        self.busy(SCAN_TIME_PER_CHANNEL_S * len(self.scan_list))
        return readings

    def _reading(self, number: int) -> float:
        config = self.channels.get(number)
        if config is None:
            return self.lab.noisy(0.0, 1e-6)
        quantity = self.lab.config.thermocouple_channels.get(number)
        if quantity is None or number in self.lab.faults.open_thermocouples:
            return OVERLOAD if config.open_check else -OVERLOAD
        celsius = self.lab.noisy(self.lab.temperature_c(quantity), self.lab.config.noise.thermocouple_k)
        if config.unit == "F":
            return celsius * 9 / 5 + 32
        return celsius + 273.15 if config.unit == "K" else celsius


class Keysight34970AEmulator(DAQ970AEmulator):
    """The HP/Agilent 34970A: same commands, its own identity and a 10-deep error queue [34970A-UG p.268]."""

    name = "34970a"
    identity = "HEWLETT-PACKARD,34970A,0,13-2-2"
    error_queue_size = 10
