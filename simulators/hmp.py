"""HMP4040 emulator: four outputs that drive the simulated lab's heaters.

Written from the public sources on the HMP's SCPI set, not from the driver:
  [HMP-DS]  R&S HMP datasheet: HMP4040 4 x 0-32 V, 10 A, 160 W per output
  [pym-HMP] pymeasure, instruments/rohdeschwarz/hmp.py; [qc-HMP] QCoDeS contrib, RohdeSchwarz/private/HMP.py
  [sigrok]  libsigrok src/hardware/scpi-pps/profiles.c (rs_hmp4040_cmd, the 32.050 V / 10.010 A maxima)
  [chk]     charkster/hmp4040 hmp4040.py (power-on readbacks, OUTP:SEL / OUTP:GEN wording)
Speaks ``INST OUT<n>`` / ``INST:SEL OUT<n>`` /
``INST:NSEL <n>`` select; ``VOLT``, ``CURR`` (with optional ``SOUR:`` and ``:LEV:IMM:AMPL``
nodes) set and query the selected output (``12.000``, ``1.5000`` [chk]); ``OUTP:SEL`` arms it,
``OUTP:GEN`` is the master switch, ``OUTP ON`` arms it and turns the master on, ``OUTP OFF``
disarms it; ``MEAS:VOLT?`` / ``MEAS:CURR?`` read the lab's output (3 / 4 decimals).
An output is live when it is armed AND the master is on; that is what the lab's ``on`` flag
holds, and every change goes through ``lab.set_supply`` so temperatures integrate with the
settings that were in force.

Further commands, as the HMP SCPI command list names them and [pym-HMP] sends them: ``APPL V,I``
and ``APPL?`` (``12.000,1.5000``) for the selected output; ``VOLT:STEP``/``CURR:STEP`` (and ``?``)
with ``VOLT UP|DOWN``, ``CURR UP|DOWN``; ``VOLT MIN|MAX`` and the queries ``VOLT? MIN|MAX``,
``CURR? MIN|MAX``, which answer the limits, not the present setting; ``MEAS:POW?`` (W, 3
decimals); over-voltage protection ``VOLT:PROT[:LEV]``, ``VOLT:PROT:MODE MEAS|PROT``,
``VOLT:PROT:TRIP?``, ``VOLT:PROT:CLE``; the electronic fuse ``FUSE[:STAT] ON|OFF``, ``FUSE:DEL``
(ms), ``FUSE:TRIP?``; ``SYST:VERS?`` (the SCPI version, ``1999.0``); ``SYST:BEEP``. A tripped
protection or fuse disarms its output; a trip is looked for whenever a command is handled.

Assumptions, not from a manual: out-of-range values are refused with -222 "Data out of range"
(the setting is kept); the accepted ranges are 0-32.050 V and 0-10.010 A [sigrok,
qc-HMP]; *RST gives 0 V, 0.1 A, all off, output 1 selected (the power-on readbacks [chk]); the
160 W per-output power limit is not modelled; steps default to 1.000 V and 0.1000 A; the OVP level
defaults to the voltage maximum; the fuse trips when the output is current-limited for longer than
its delay (0-250 ms, default 0) and stays tripped (the output cannot be armed) until FUSE OFF.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import ClassVar

from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.simulators.scpi import SCPIEmulator, SCPIError

MAX_VOLTAGE_V = 32.050
MAX_CURRENT_A = 10.010
FUSE_DELAY_RANGE_MS = (0, 250)
SCPI_VERSION = "1999.0"


@dataclass
class OutputChannel:
    """Settings of one output as the supply holds them."""

    voltage_v: float = 0.0
    current_limit_a: float = 0.1
    armed: bool = False
    voltage_step_v: float = 1.0
    current_step_a: float = 0.1
    ovp_level_v: float = MAX_VOLTAGE_V
    ovp_measured: bool = True
    ovp_tripped: bool = False
    fuse_on: bool = False
    fuse_delay_ms: int = 0
    fuse_tripped: bool = False
    limited_since: float | None = None


class HMPEmulator(SCPIEmulator):
    """An R&S HMP4040 whose outputs 1 and 2 feed the target and thermal-box heaters."""

    name = "hmp4040"
    identity = "ROHDE&SCHWARZ,HMP4040,101234,HW50020003/SW2.51"
    outputs = 4
    commands: ClassVar[dict[str, str]] = {
        "INSTrument[:SELect]": "select",
        "INSTrument[:SELect]?": "selected",
        "INSTrument:NSELect": "select_number",
        "INSTrument:NSELect?": "selected_number",
        "[SOURce:]VOLTage[:LEVel][:IMMediate][:AMPLitude]": "set_voltage",
        "[SOURce:]VOLTage[:LEVel][:IMMediate][:AMPLitude]?": "voltage",
        "[SOURce:]CURRent[:LEVel][:IMMediate][:AMPLitude]": "set_current",
        "[SOURce:]CURRent[:LEVel][:IMMediate][:AMPLitude]?": "current",
        "OUTPut[:STATe]": "set_output",
        "OUTPut[:STATe]?": "output",
        "OUTPut:SELect": "set_armed",
        "OUTPut:SELect?": "armed",
        "OUTPut:GENeral": "set_master",
        "OUTPut:GENeral?": "master",
        "MEASure[:SCALar]:VOLTage[:DC]?": "measure_voltage",
        "MEASure[:SCALar]:CURRent[:DC]?": "measure_current",
        "SYSTem:REMote": "_nothing",
        "SYSTem:LOCal": "_nothing",
        "SYSTem:MIXed": "_nothing",
        "SYSTem:RWLock": "_nothing",
        "APPLy": "apply",
        "APPLy?": "applied",
        "[SOURce:]VOLTage[:LEVel]:STEP[:INCRement]": "set_voltage_step",
        "[SOURce:]VOLTage[:LEVel]:STEP[:INCRement]?": "voltage_step",
        "[SOURce:]CURRent[:LEVel]:STEP[:INCRement]": "set_current_step",
        "[SOURce:]CURRent[:LEVel]:STEP[:INCRement]?": "current_step",
        "MEASure[:SCALar]:POWer?": "measure_power",
        "[SOURce:]VOLTage:PROTection[:LEVel]": "set_ovp_level",
        "[SOURce:]VOLTage:PROTection[:LEVel]?": "ovp_level",
        "[SOURce:]VOLTage:PROTection:MODE": "set_ovp_mode",
        "[SOURce:]VOLTage:PROTection:MODE?": "ovp_mode",
        "[SOURce:]VOLTage:PROTection:TRIPped?": "ovp_tripped",
        "[SOURce:]VOLTage:PROTection:CLEar": "clear_ovp",
        "FUSE[:STATe]": "set_fuse",
        "FUSE[:STATe]?": "fuse",
        "FUSE:DELay": "set_fuse_delay",
        "FUSE:DELay?": "fuse_delay",
        "FUSE:TRIPped?": "fuse_tripped",
        "SYSTem:VERSion?": "scpi_version",
        "SYSTem:BEEPer[:IMMediate]": "beep",
    }

    def __init__(self, lab: SimulatedLab) -> None:
        """Take over whatever state the lab's supply is in, as a supply found switched on would be."""
        super().__init__(lab)
        supply = lab.supply
        self.channels = {n: OutputChannel(supply[n].voltage_v, supply[n].current_limit_a, supply[n].on)
                         for n in range(1, self.outputs + 1)}
        self.master_on = any(channel.armed for channel in self.channels.values())
        self.selected_output = 1

    def reset(self) -> None:
        self.channels = {n: OutputChannel() for n in range(1, self.outputs + 1)}
        self.master_on = False
        self.selected_output = 1
        self._sync()

    def _sync(self) -> None:
        """Hand the settings to the lab: live = armed and master on."""
        for number, channel in self.channels.items():
            self.lab.set_supply(number, voltage_v=channel.voltage_v, current_limit_a=channel.current_limit_a,
                                on=channel.armed and self.master_on)
        self._protect()

    def execute(self, header: str, argument: str) -> str | None:
        """Every command first sees whether a protection tripped since the last one."""
        self._protect()
        return super().execute(header, argument)

    def _protect(self) -> None:
        """Disarm an output whose OVP level is exceeded or whose fuse saw the current limit for its delay."""
        now = self.lab.clock.now()
        for number, channel in self.channels.items():
            if not (channel.armed and self.master_on):
                channel.limited_since = None
                continue
            volts, amps = self.lab.supply_readback(number)
            seen_v = volts if channel.ovp_measured else channel.voltage_v
            if seen_v > channel.ovp_level_v + 1e-9:
                channel.ovp_tripped = True
            limited = amps >= channel.current_limit_a - 1e-9 and channel.current_limit_a > 0
            channel.limited_since = (channel.limited_since if channel.limited_since is not None else now) \
                if limited else None
            if (channel.fuse_on and channel.limited_since is not None
                    and now - channel.limited_since >= channel.fuse_delay_ms / 1000):
                channel.fuse_tripped = True
            if channel.ovp_tripped or channel.fuse_tripped:
                channel.armed = False
                channel.limited_since = None
                self.lab.set_supply(number, on=False)

    @property
    def channel(self) -> OutputChannel:
        return self.channels[self.selected_output]

    # -- selection ------------------------------------------------------------------------------
    def select(self, argument: str) -> None:
        if not argument:
            raise SCPIError(-109)
        match = re.fullmatch(r"OUT(?:P(?:UT)?)?\s*(\d+)", argument, re.IGNORECASE)
        if match is None or not 1 <= int(match.group(1)) <= self.outputs:
            raise SCPIError(-224)
        self.selected_output = int(match.group(1))

    def selected(self, _: str) -> str:
        return f"OUT{self.selected_output}"

    def select_number(self, argument: str) -> None:
        number = self.number(argument, 1, self.outputs)
        if not number.is_integer():
            raise SCPIError(-224)
        self.selected_output = int(number)

    def selected_number(self, _: str) -> str:
        return str(self.selected_output)

    # -- settings -------------------------------------------------------------------------------
    @staticmethod
    def _stepped(argument: str, present: float, step: float, high: float) -> float:
        """A set value: a number, MIN|MAX, or UP|DOWN by the output's step (refused beyond the range)."""
        word = argument.strip().upper()
        if word in ("UP", "DOWN"):
            value = present + (step if word == "UP" else -step)
            if not -1e-9 <= value <= high + 1e-9:
                raise SCPIError(-222)
            return min(max(value, 0.0), high)
        return SCPIEmulator.number(argument, 0.0, high)

    @staticmethod
    def _limit_query(argument: str, present: float, high: float) -> float:
        """``VOLT?`` / ``CURR?``: the setting, or with MIN|MAX the limit asked for."""
        word = argument.strip().upper()
        if not word:
            return present
        if word in ("MIN", "MINIMUM", "MAX", "MAXIMUM"):
            return 0.0 if word.startswith("MIN") else high
        raise SCPIError(-224)

    def set_voltage(self, argument: str) -> None:
        channel = self.channel
        channel.voltage_v = round(self._stepped(argument, channel.voltage_v, channel.voltage_step_v,
                                                MAX_VOLTAGE_V), 3)
        self._sync()

    def voltage(self, argument: str) -> str:
        return f"{self._limit_query(argument, self.channel.voltage_v, MAX_VOLTAGE_V):.3f}"

    def set_current(self, argument: str) -> None:
        channel = self.channel
        channel.current_limit_a = round(self._stepped(argument, channel.current_limit_a, channel.current_step_a,
                                                      MAX_CURRENT_A), 4)
        self._sync()

    def current(self, argument: str) -> str:
        return f"{self._limit_query(argument, self.channel.current_limit_a, MAX_CURRENT_A):.4f}"

    def apply(self, argument: str) -> None:
        """``APPL V,I``: voltage and current limit of the selected output, both checked first."""
        parameters = self.parameters(argument)
        if len(parameters) != 2:
            raise SCPIError(-109 if len(parameters) < 2 else -108)
        volts = self.number(parameters[0], 0.0, MAX_VOLTAGE_V)
        amps = self.number(parameters[1], 0.0, MAX_CURRENT_A)
        self.channel.voltage_v, self.channel.current_limit_a = round(volts, 3), round(amps, 4)
        self._sync()

    def applied(self, argument: str) -> str:
        self.no_parameter(argument)
        return f"{self.channel.voltage_v:.3f},{self.channel.current_limit_a:.4f}"

    def set_voltage_step(self, argument: str) -> None:
        self.channel.voltage_step_v = round(self.number(argument, 0.0, MAX_VOLTAGE_V), 3)

    def voltage_step(self, argument: str) -> str:
        self.no_parameter(argument)
        return f"{self.channel.voltage_step_v:.3f}"

    def set_current_step(self, argument: str) -> None:
        self.channel.current_step_a = round(self.number(argument, 0.0, MAX_CURRENT_A), 4)

    def current_step(self, argument: str) -> str:
        self.no_parameter(argument)
        return f"{self.channel.current_step_a:.4f}"

    # -- protection -----------------------------------------------------------------------------
    def set_ovp_level(self, argument: str) -> None:
        self.channel.ovp_level_v = round(self.number(argument, 0.0, MAX_VOLTAGE_V), 3)
        self._sync()

    def ovp_level(self, argument: str) -> str:
        return f"{self._limit_query(argument, self.channel.ovp_level_v, MAX_VOLTAGE_V):.3f}"

    def set_ovp_mode(self, argument: str) -> None:
        word = argument.strip().upper()
        if not word:
            raise SCPIError(-109)
        if word not in ("MEAS", "MEASURED", "PROT", "PROTECTED"):
            raise SCPIError(-224)
        self.channel.ovp_measured = word.startswith("MEAS")
        self._sync()

    def ovp_mode(self, argument: str) -> str:
        self.no_parameter(argument)
        return "MEAS" if self.channel.ovp_measured else "PROT"

    def ovp_tripped(self, argument: str) -> str:
        self.no_parameter(argument)
        return str(int(self.channel.ovp_tripped))

    def clear_ovp(self, argument: str) -> None:
        self.no_parameter(argument)
        self.channel.ovp_tripped = False

    def set_fuse(self, argument: str) -> None:
        on = self.boolean(argument)
        self.channel.fuse_on = on
        if not on:
            self.channel.fuse_tripped = False
        self._sync()

    def fuse(self, argument: str) -> str:
        self.no_parameter(argument)
        return str(int(self.channel.fuse_on))

    def set_fuse_delay(self, argument: str) -> None:
        self.channel.fuse_delay_ms = self.integer(argument, *FUSE_DELAY_RANGE_MS)

    def fuse_delay(self, argument: str) -> str:
        self.no_parameter(argument)
        return str(self.channel.fuse_delay_ms)

    def fuse_tripped(self, argument: str) -> str:
        self.no_parameter(argument)
        return str(int(self.channel.fuse_tripped))

    def scpi_version(self, argument: str) -> str:
        self.no_parameter(argument)
        return SCPI_VERSION

    def beep(self, argument: str) -> None:
        self.no_parameter(argument)

    # -- switching ------------------------------------------------------------------------------
    def set_output(self, argument: str) -> None:
        on = self.boolean(argument)
        self.channel.armed = on
        self.master_on = self.master_on or on
        self._sync()

    def output(self, _: str) -> str:
        return str(int(self.channel.armed and self.master_on))

    def set_armed(self, argument: str) -> None:
        self.channel.armed = self.boolean(argument)
        self._sync()

    def armed(self, _: str) -> str:
        return str(int(self.channel.armed))

    def set_master(self, argument: str) -> None:
        self.master_on = self.boolean(argument)
        self._sync()

    def master(self, _: str) -> str:
        return str(int(self.master_on))

    # -- measuring ------------------------------------------------------------------------------
    def measure_voltage(self, _: str) -> str:
        return f"{self.lab.supply_readback(self.selected_output)[0]:.3f}"

    def measure_current(self, _: str) -> str:
        return f"{self.lab.supply_readback(self.selected_output)[1]:.4f}"

    def measure_power(self, argument: str) -> str:
        self.no_parameter(argument)
        volts, amps = self.lab.supply_readback(self.selected_output)
        return f"{volts * amps:.3f}"
