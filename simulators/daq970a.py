"""DAQ970A / 34970A emulator: thermocouple channels scanned from the simulated lab's temperatures.

Written from the manuals, not from the driver (its tables are the emulator's own):
  [34970A-UG]   Agilent/HP 34970A User's Guide: ch.4 "To Build a Scan List" and "Rules for Using
                a Channel List", ch.5 CONFigure / ROUTe:SCAN (p.228), SYSTem:ERRor? (p.268)
  [34980A-help] 34980A online help (the same SCPI tree): CONFigure:TEMPerature, UNIT:TEMPerature,
                [SENSe:]TEMPerature:TRANsducer:TCouple:RJUNction:TYPE
  [dvg]         Dennis-van-Gils/python-dvg-devices, Keysight_3497xA_protocol_SCPI.py (*OPC? reply)
Speaks ``CONF:TEMP``, ``MEAS:TEMP?``, ``UNIT:TEMP``, ``SENS:TEMP:TRAN:TC:RJUN:TYPE``,
``SENS:TEMP:TRAN:TC:CHEC``, ``SENS:TEMP:NPLC`` (and ``?``), ``ROUT:SCAN``, ``ROUT:SCAN?``
(definite-length block ``#214(@101,102,103)``, empty ``#13(@)``), ``ROUT:SCAN:SIZE?``, ``READ?``,
``INIT`` + ``FETC?`` (a scan into reading memory, then its readings; READ? = INIT + FETC?
[34970A-UG ch.5 "INITiate", "FETCh?"]), ``ABOR``, ``ROUT:OPEN``/``ROUT:CLOS`` (and their ``?``
forms: 1 per channel in the state asked about), ``SYST:CTYP? <slot>`` (the module in a slot:
``...,34901A,0,1.0``; an empty slot ``...,0,0,0`` [34970A-UG ch.5 SYSTem:CTYPe?; dvg]),
``DISP:TEXT``, and the diagnostics dvg's client reads at start-up: ``DIAG:DMM:CYCL?`` (relay
cycles of the internal DMM's three slot relays), ``DIAG:REL:CYCL? (@list)`` (per channel),
``DIAG:PEEK:SLOT:DATA? <slot>`` (the module's stored label) [dvg, 34970A-UG ch.5 DIAGnostic].
The common commands and the status model are scpi.py's.
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
  - a channel in the scan list but never configured reads as DC volts with nothing on it;
  - ``NPLC`` takes 0.02, 0.2, 1, 2, 10, 20, 100 or 200 (a value in between is rounded up); a channel
    costs max(0.1 s, NPLC / 50 Hz) of the scan;
  - ``FETC?`` with nothing in reading memory is -230 "Data corrupt or stale" and sends nothing;
    ``*RST`` and a new CONF empty the memory;
  - a scan opens every relay it used; a relay closes once per channel per scan (the cycle counts).
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
#: Integration times in power-line cycles the DMM offers (34970A; see the assumptions above).
NPLC_VALUES: tuple[float, ...] = (0.02, 0.2, 1.0, 2.0, 10.0, 20.0, 100.0, 200.0)
MAINS_HZ = 50.0
#: ``SYST:CTYP?`` vendor field and module of slot 1 per model; ``,0,0,0`` for an empty slot.
MODULE = "34901A"


@dataclass
class ThermocoupleChannel:
    """What a channel was configured for (the *RST state after CONF, then the changes sent)."""

    tc_type: str
    unit: str = "C"
    reference_junction: str = "INT"
    open_check: bool = False
    nplc: float = 1.0


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
        "INITiate[:IMMediate]": "initiate",
        "FETCh?": "fetch",
        "ABORt": "abort",
        "[SENSe:]TEMPerature:NPLCycles": "set_nplc",
        "[SENSe:]TEMPerature:NPLCycles?": "nplc",
        "ROUTe:OPEN": "open_relays",
        "ROUTe:CLOSe": "close_relays",
        "ROUTe:OPEN?": "relays_open",
        "ROUTe:CLOSe?": "relays_closed",
        "SYSTem:CTYPe?": "card_type",
        "DISPlay:TEXT": "set_display_text",
        "DISPlay:TEXT:CLEar": "_nothing",
        "DIAGnostic:DMM:CYCLes?": "dmm_cycles",
        "DIAGnostic:RELay:CYCLes?": "relay_cycles",
        "DIAGnostic:PEEK:SLOT:DATA?": "slot_label",
    }
    signed_registers = True
    #: Vendor field of ``SYST:CTYP?`` (the module's maker as this mainframe reports it).
    module_vendor: ClassVar[str] = "Keysight Technologies"
    module_name: ClassVar[str] = "DAQM901A"

    def __init__(self, lab: SimulatedLab) -> None:
        super().__init__(lab)
        self.relay_counts: dict[int, int] = {}
        self.dmm_relay_cycles = dict.fromkeys(MAINFRAME_SLOTS, 0)
        self.display_text = ""
        self.reset()

    def reset(self) -> None:
        self.channels: dict[int, ThermocoupleChannel] = {}
        self.scan_list: list[int] = []
        self.closed: set[int] = set()
        self.memory: str | None = None

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
        self.memory = None

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

    def set_nplc(self, argument: str) -> None:
        """``SENS:TEMP:NPLC <PLC>[,(@list)]``: integration time, rounded up to the next value offered."""
        parameters = self.parameters(argument)
        value = self.number(parameters[0] if parameters else "", NPLC_VALUES[0], NPLC_VALUES[-1])
        nplc = next(v for v in NPLC_VALUES if v >= value - 1e-12)
        for channel in self._targets(parameters):
            channel.nplc = nplc

    def nplc(self, argument: str) -> str:
        numbers = self.channel_list(argument) if argument else self.scan_list
        if any(n not in self.channels for n in numbers):
            raise SCPIError(-221)
        return ",".join(f"{self.channels[n].nplc:+.8E}" for n in numbers)

    # -- relays and modules -------------------------------------------------------------------
    def open_relays(self, argument: str) -> None:
        if not argument:
            raise SCPIError(-109)
        self.closed -= set(self.channel_list(argument))

    def close_relays(self, argument: str) -> None:
        if not argument:
            raise SCPIError(-109)
        for number in self.channel_list(argument):
            if number not in self.closed:
                self.closed.add(number)
                self.relay_counts[number] = self.relay_counts.get(number, 0) + 1

    def relays_closed(self, argument: str) -> str:
        return ",".join("1" if n in self.closed else "0" for n in self.channel_list(argument))

    def relays_open(self, argument: str) -> str:
        return ",".join("0" if n in self.closed else "1" for n in self.channel_list(argument))

    def _slot(self, argument: str) -> int:
        """A slot named as 100, 200 or 300 (or 1-3)."""
        slot = self.integer(argument, 1, 300)
        slot = slot // 100 if slot >= 100 else slot
        if slot not in MAINFRAME_SLOTS:
            raise SCPIError(-222)
        return slot

    def card_type(self, argument: str) -> str:
        if self._slot(argument) in INSTALLED_SLOTS:
            return f"{self.module_vendor},{self.module_name},0,1.0"
        return f"{self.module_vendor},0,0,0"

    def set_display_text(self, argument: str) -> None:
        text = argument.strip()
        if len(text) < 2 or text[0] not in "'\"" or text[-1] != text[0]:
            raise SCPIError(-104)
        self.display_text = text[1:-1]

    def dmm_cycles(self, argument: str) -> str:
        self.no_parameter(argument)
        return ",".join(f"{self.dmm_relay_cycles[slot]:+d}" for slot in MAINFRAME_SLOTS)

    def relay_cycles_of(self, number: int) -> int:
        return self.relay_counts.get(number, 0)

    def relay_cycles(self, argument: str) -> str:
        if not argument:
            raise SCPIError(-109)
        return ",".join(f"{self.relay_cycles_of(n):+d}" for n in self.channel_list(argument))

    def slot_label(self, argument: str) -> str:
        slot = self._slot(argument)
        return f'"SIM{slot}00"' if slot in INSTALLED_SLOTS else '""'

    # -- scanning -----------------------------------------------------------------------------
    def _scan(self) -> str:
        """One sweep of the scan list: readings taken now, ready when the sweep is done."""
        if not self.scan_list:
            raise SCPIError(-221)
        readings = ",".join(f"{self._reading(channel):+.8E}" for channel in self.scan_list)
        for number in self.scan_list:
            self.relay_counts[number] = self.relay_counts.get(number, 0) + 1
            self.dmm_relay_cycles[number // 100] += 1
        self.closed.clear()
        self.busy(sum(self._channel_time(number) for number in self.scan_list))
        return readings

    def _channel_time(self, number: int) -> float:
        channel = self.channels.get(number)
        return max(SCAN_TIME_PER_CHANNEL_S, (channel.nplc if channel else 1.0) / MAINS_HZ)

    def read(self, argument: str) -> str:
        """``READ?`` = ``INIT`` then ``FETC?``; the reply is ready when the sweep is done."""
        self.no_parameter(argument)
        self.memory = self._scan()
        return self.memory

    def initiate(self, argument: str) -> None:
        """``INIT``: start a sweep into reading memory; no reply."""
        self.no_parameter(argument)
        self.memory = self._scan()

    def fetch(self, argument: str) -> str:
        """``FETC?``: the readings in memory, once the sweep is done (they stay in memory)."""
        self.no_parameter(argument)
        if self.memory is None:
            raise SCPIError(-230)
        return self.memory

    def abort(self, argument: str) -> None:
        self.no_parameter(argument)

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
    module_vendor = "HEWLETT-PACKARD"
    module_name = MODULE
