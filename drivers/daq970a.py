"""Keysight DAQ970A / Agilent (HP) 34970A data acquisition unit as a thermocouple scanner (SCPI).

Sources (facts cited where used):
  [34970A-UG]   Agilent/HP 34970A User's Guide: ch.4 "Rules for Using a Channel List",
                "To Build a Scan List", "Firmware Revision Query" (p.146); ch.5 ROUTe:SCAN (p.228),
                SYSTem:ERRor? (p.268), Questionable Data register (p.280)
  [3497x-UG-KS] Keysight 34970A/34972A User's Guide, ch.4 "Flow control selection (RS-232)" pp.192-193
  [DAQ970-PG]   Keysight DAQ970A/DAQ973A Programming Guide, *IDN? (p.149)
  [34980A-help] 34980A online help, RJUNction:EXTernal? (the 9.9E+37 invalid value; sister product)
  [dvg]         Dennis-van-Gils/python-dvg-devices, src/dvg_devices/Keysight_3497xA_protocol_SCPI.py
The set-up sequence is dvg's (CONF:TEMP, UNIT:TEMP, RJUN:TYPE INT, TC:CHECk ON, ROUT:SCAN, then
drain SYST:ERR?). Readings come back comma-separated in ascending channel order, whatever order
the channels were named in [34970A-UG ch.5: the scan runs from slot 100 up]. An open thermocouple
or overload reads +/-9.9E+37 [34980A-help]; the 34970A puts *no* error in the queue for an
overload [34970A-UG p.280], so the driver must look at every value.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ecds_lab.drivers.instrument import SCPIInstrument
from ecds_lab.drivers.replies import NR3, Field, ReplyFormat, ask_checked
from ecds_lab.errors import InvalidSettingError, ReplyFormatError, TransportTimeout
from ecds_lab.transports.base import Transport

#: The eight standard letter types; that the DMM takes exactly these was not re-checked in the manual.
TC_TYPES: tuple[str, ...] = ("B", "E", "J", "K", "N", "R", "S", "T")
#: Slots 1-3, channels 01-20 of a 20-channel multiplexer (34901A / DAQM901A) [34970A-UG ch.4].
SLOTS: tuple[int, ...] = (1, 2, 3)
MUX_CHANNELS = 20
DEFAULT_CHANNELS: Mapping[str, int] = {"coil": 101, "target": 102, "ambient": 103}
#: Readings at or beyond this magnitude are the overload / open-input value 9.9E+37 [34980A-help].
OVERLOAD_THRESHOLD = 9.0e37
#: ``READ?`` -> one NR3 reading per channel of the scan list, e.g. ``+2.21234567E+01`` [34970A-UG
#: ch.5]; READ? starts a new scan, so a garbled reply is re-queried once (a fresh scan).
READ_REPLY = ReplyFormat((Field("reading", NR3),), count=1)
#: Thermocouples read from about -270 C (type E/J/K/T lower end) to 1820 C (type B upper end);
#: anything outside (short of the overload value) is not a temperature.
PLAUSIBLE_C = (-273.15, 1820.0)
#: Models that speak this command set; matched on the 2nd *IDN? field [dvg: the vendor field varies].
MODELS: tuple[str, ...] = ("DAQ970A", "DAQ973A", "34970A", "34972A")

#: RS-232 of the 34970A: 9600 8N1 and LF as public scripts use; replies end in CR LF, which the
#: transport strips [dvg]. The factory flow control is XON/XOFF [3497x-UG-KS pp.192-193], set only
#: from the front panel, so the link uses it too. READ? needs >= 5 s [dvg].
SERIAL_SETTINGS: dict[str, Any] = {
    "baudrate": 9600, "bytesize": 8, "parity": "N", "stopbits": 1, "xonxoff": True,
    "write_termination": "\n", "read_termination": "\n", "timeout_s": 5.0,
}
#: GPIB / LAN / USB through VISA: LF both ways [dvg].
VISA_SETTINGS: dict[str, Any] = {"write_termination": "\n", "read_termination": "\n", "timeout_s": 5.0}


def channel_list(channels: Sequence[int]) -> str:
    """SCPI channel list ``(@...)``: a range when the channels are consecutive, else a list [34970A-UG ch.4]."""
    numbers = sorted(channels)
    if len(numbers) > 1 and numbers == list(range(numbers[0], numbers[-1] + 1)):
        return f"(@{numbers[0]}:{numbers[-1]})"
    return "(@" + ",".join(str(n) for n in numbers) + ")"


class DAQ970A(SCPIInstrument):
    """Named thermocouple channels on a DAQ970A or 34970A: ``configure`` once, then ``read_temperatures_c``."""

    model = "DAQ970A"

    def __init__(self, transport: Transport, *, channels: Mapping[str, int] | None = None,
                 thermocouple_type: str = "K") -> None:
        super().__init__(transport)
        self.channels = self._check_channels(DEFAULT_CHANNELS if channels is None else channels)
        tc_type = str(thermocouple_type).upper()
        if tc_type not in TC_TYPES:
            raise InvalidSettingError(
                f"{self.name}.thermocouple_type: {thermocouple_type!r} is not one of {', '.join(TC_TYPES)}")
        self.thermocouple_type = tc_type
        self.detected_model: str | None = None

    def _check_channels(self, channels: Mapping[str, int]) -> dict[int, str]:
        """Channel number -> name in scan (ascending) order; raises before anything is sent."""
        if not channels:
            raise InvalidSettingError(f"{self.name}.channels: at least one channel is needed")
        by_number: dict[int, str] = {}
        for name, number in channels.items():
            label = f"{self.name}.channels[{name!r}]"
            if isinstance(number, bool) or not isinstance(number, int):
                raise InvalidSettingError(f"{label}: {number!r} is not a channel number such as 101")
            if number // 100 not in SLOTS or not 1 <= number % 100 <= MUX_CHANNELS:
                raise InvalidSettingError(f"{label}: {number} is not a multiplexer channel (101-120, 201-220, 301-320)")
            if number in by_number:
                raise InvalidSettingError(f"{label}: channel {number} is already used by {by_number[number]!r}")
            by_number[number] = name
        return dict(sorted(by_number.items()))

    # -- TemperatureScanner interface ----------------------------------------------------------
    def identity(self) -> str:
        """``*IDN?``; refuses an instrument not of the 3497x / DAQ970 family [34970A-UG p.146, DAQ970-PG p.149]."""
        reply = self.ask("*IDN?")
        fields = [field.strip() for field in reply.split(",")]
        model = fields[1].upper() if len(fields) > 1 else ""
        if model not in MODELS:
            raise self.fail("*IDN?", reply, f"not a {' / '.join(MODELS)}")
        self.detected_model = model
        return reply

    def configure(self) -> None:
        """Thermocouples in degrees C, internal reference junction, open-TC check on, scan list = the channels."""
        channels = channel_list(list(self.channels))
        commands = [
            f"CONF:TEMP TC,{self.thermocouple_type},{channels}",
            f"UNIT:TEMP C,{channels}",
            f"SENS:TEMP:TRAN:TC:RJUN:TYPE INT,{channels}",
            f"SENS:TEMP:TRAN:TC:CHEC ON,{channels}",
            f"ROUT:SCAN {channels}",
        ]
        for command in commands:
            self.write(command)
        self.check_errors("; ".join(commands))

    def read_temperatures_c(self) -> dict[str, float]:
        """One scan (``READ?``): {name: degrees C}; an open thermocouple is an error, never a temperature."""
        try:
            reply, values = ask_checked(self, "READ?", READ_REPLY, count=len(self.channels))
        except TransportTimeout:
            errors = self.error_queue()  # a refused query sends nothing; the queue says why
            if errors:
                raise self.fail("READ?", errors[0], "; ".join(errors[1:])) from None
            raise
        temperatures: dict[str, float] = {}
        for (number, name), value in zip(self.channels.items(), values, strict=True):
            if abs(value) >= OVERLOAD_THRESHOLD:
                raise self.fail("READ?", reply, f"channel {number} ({name!r}): open thermocouple or overload")
            if not PLAUSIBLE_C[0] <= value <= PLAUSIBLE_C[1]:
                raise ReplyFormatError(self.name, "READ?", reply, f"channel {number} ({name!r}) reads {value:g} C, "
                                       f"not a thermocouple temperature ({PLAUSIBLE_C[0]:g}..{PLAUSIBLE_C[1]:g} C)")
            temperatures[name] = value
        return temperatures


class Keysight34970A(DAQ970A):
    """The older 34970A: the same commands; answers ``HEWLETT-PACKARD,34970A,0,13-2-2`` [34970A-UG p.146]."""

    model = "34970A"

