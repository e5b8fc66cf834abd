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

Assumptions, not from a manual: out-of-range values are refused with -222 "Data out of range"
(the setting is kept); the accepted ranges are 0-32.050 V and 0-10.010 A [sigrok,
qc-HMP]; *RST gives 0 V, 0.1 A, all off, output 1 selected (the power-on readbacks [chk]); the
160 W per-output power limit is not modelled.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import ClassVar

from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.simulators.scpi import SCPIEmulator, SCPIError

MAX_VOLTAGE_V = 32.050
MAX_CURRENT_A = 10.010


@dataclass
class OutputChannel:
    """Settings of one output as the supply holds them."""

    voltage_v: float = 0.0
    current_limit_a: float = 0.1
    armed: bool = False


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
    def set_voltage(self, argument: str) -> None:
        self.channel.voltage_v = round(self.number(argument, 0.0, MAX_VOLTAGE_V), 3)
        self._sync()

    def voltage(self, _: str) -> str:
        return f"{self.channel.voltage_v:.3f}"

    def set_current(self, argument: str) -> None:
        self.channel.current_limit_a = round(self.number(argument, 0.0, MAX_CURRENT_A), 4)
        self._sync()

    def current(self, _: str) -> str:
        return f"{self.channel.current_limit_a:.4f}"

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
