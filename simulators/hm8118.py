"""HM8118 LCR bridge emulator: the bridge's serial protocol over the simulated lab's coil.

Written from the instrument's manual, not from the driver (its tables are the emulator's own):
  [M32] HM8118 manual, ch. 10 "Command reference", sections 10.1-10.2, p. 32 (mnemonics, codes)
  [M23] HM8118 manual (German), "Befehlsliste", p. 23 (``ERROR`` for a refused command)
  [M50] HM8118 manual, s. 7.3.2, p. 50 (compensation over the 69 test frequencies)
  [SPEC] HM8118 data sheet: test frequencies 20 Hz-200 kHz, test signal 50 mV-1.5 V rms
CR-terminated commands, silent set commands, ``ERROR`` for anything refused,
``XALL?`` -> ``main,secondary,bin``. Measurement times and noise per speed are
assumptions (the vendor's figures were not found): fast 70 ms, medium 190 ms, slow
600 ms per reading.
"""

from __future__ import annotations

import cmath
import math

from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.lab import SimulatedLab

IDENTITY = "HAMEG Instruments, HM8118,013206727,1.57"
#: The bridge steps its test frequency through the same 17 values in every decade
#: (1, 1.2, 1.5, 1.8, 2, 2.4, 2.5, 3, 3.6, 4, 4.5, 5, 6, 7.2, 7.5, 8, 9), from 20 Hz up to
#: 200 kHz: 69 frequencies in all [SPEC, M50].
_STEPS_PER_DECADE = (10, 12, 15, 18, 20, 24, 25, 30, 36, 40, 45, 50, 60, 72, 75, 80, 90)
FREQUENCIES_HZ: frozenset[int] = frozenset(
    step * 10 ** decade for decade in range(6) for step in _STEPS_PER_DECADE if 20 <= step * 10 ** decade <= 200_000)
#: ``VOLT``: test signal level in V rms [SPEC].
VOLTAGE_RANGE_V = (0.05, 1.5)
#: ``PMOD`` codes [M32]: the main-secondary display pair (10 and 11 need the HZ186 fixture).
FUNCTION_CODES = {0: "AUTO", 1: "L-Q", 2: "L-R", 3: "C-D", 4: "C-R", 5: "R-Q", 6: "Z-theta", 7: "Y-theta",
                  8: "R-X", 9: "G-B", 10: "N-theta", 11: "M"}
#: ``CIRC`` codes [M32].
CIRCUIT_CODES = {0: "series", 1: "parallel", 2: "auto"}
#: ``RATE`` codes [M32], named as the lab's noise model names them.
SPEED_CODES = {0: "fast", 1: "medium", 2: "slow"}
#: ``MMOD`` codes [M32].
TRIGGER_CODES = {0: "continuous", 1: "manual", 2: "external"}
#: ``NAVG``: readings averaged when ``AVGM`` is on [M32].
AVERAGES_RANGE = (2, 99)
MEASUREMENT_TIME_S = {0: 0.07, 1: 0.19, 2: 0.6}
COMPENSATION_TIME_S = 1.5  # per frequency


class HM8118Emulator(LineEmulator):
    name = "hm8118"
    line_endings = b"\r\n"
    reply_termination = b"\r"

    def __init__(self, lab: SimulatedLab) -> None:
        super().__init__(lab)
        self._commands = {
            "*IDN?": lambda: self._answer(IDENTITY),
            "*RST": self.reset,
            "*OPC?": lambda: self._answer("1"),
            "*WAI": lambda: None,
            "*TRG": self._trigger,
            "XALL?": self._read_all,
            "XMAJ?": lambda: self._read_one(0),
            "XMIN?": lambda: self._read_one(1),
            "CROP": lambda: self._compensate("CROP"),
            "CRSH": lambda: self._compensate("CRSH"),
        }
        self.reset()

    def reset(self) -> None:
        self.settings = {"FREQ": 1000, "VOLT": 1.0, "PMOD": 0, "CIRC": 2, "RATE": 1, "AVGM": 0, "NAVG": 2,
                         "MMOD": 0, "CALL": 0}
        self.busy_until = self.lab.clock.now()
        self.last_values: tuple[float, float] | None = None

    # -- protocol --------------------------------------------------------------------------
    def handle_line(self, line: str) -> None:
        for command in line.split(";"):
            command = command.strip()
            if command:
                self._handle(command)

    def _answer(self, text: str) -> None:
        """Replies wait until the measurement in progress is done (one command at a time)."""
        self.reply(text, max(0.0, self.busy_until - self.lab.clock.now()))

    def _handle(self, command: str) -> None:
        mnemonic, _, argument = command.partition(" ")
        mnemonic = mnemonic.upper()
        argument = argument.strip()
        refused = self.lab.faults.bridge_error_commands
        if refused and mnemonic not in ("CROP", "CRSH") and (
                mnemonic.rstrip("?") in refused or command.upper() in refused):
            self._answer("ERROR")
            return
        handler = self._commands.get(mnemonic)
        if handler is not None and not argument:
            handler()
        elif mnemonic.endswith("?") and mnemonic[:-1] in self.settings and not argument:
            self._answer(self._format_setting(mnemonic[:-1]))
        elif mnemonic in self.settings and argument:
            self._set(mnemonic, argument)
        else:
            self._answer("ERROR")

    def _set(self, mnemonic: str, argument: str) -> None:
        try:
            value = float(argument)
        except ValueError:
            self._answer("ERROR")
            return
        valid = {
            "FREQ": value in FREQUENCIES_HZ,
            "VOLT": VOLTAGE_RANGE_V[0] <= value <= VOLTAGE_RANGE_V[1],
            "PMOD": value in FUNCTION_CODES,
            "CIRC": value in CIRCUIT_CODES,
            "RATE": value in SPEED_CODES,
            "AVGM": value in (0, 1),
            "NAVG": value.is_integer() and AVERAGES_RANGE[0] <= value <= AVERAGES_RANGE[1],
            "MMOD": value in TRIGGER_CODES,
            "CALL": value in (0, 1),
        }[mnemonic]
        if not valid:
            self._answer("ERROR")
            return
        self.settings[mnemonic] = round(value, 3) if mnemonic == "VOLT" else int(value)

    def _format_setting(self, mnemonic: str) -> str:
        value = self.settings[mnemonic]
        return f"{value:.3f}" if mnemonic == "VOLT" else str(int(value))

    def _code(self, mnemonic: str) -> int:
        """A coded setting (PMOD, CIRC, RATE, NAVG, ...) as the integer the bridge holds."""
        return int(self.settings[mnemonic])

    # -- measuring -------------------------------------------------------------------------
    def _duration(self) -> float:
        count = self._code("NAVG") if self.settings["AVGM"] else 1
        return MEASUREMENT_TIME_S[self._code("RATE")] * count

    def _trigger(self) -> None:
        """*TRG starts a measurement; the lab is sampled now, the result is ready after the measuring time."""
        start = max(self.lab.clock.now(), self.busy_until)
        self.last_values = self._measure()
        self.busy_until = start + self._duration()

    def _fresh_values(self) -> tuple[float, float] | None:
        if self.settings["MMOD"] == 0:  # continuous: always a current reading
            self._trigger()
        return self.last_values

    def _read_all(self) -> None:
        values = self._fresh_values()
        if values is None:
            self._answer("ERROR")
        else:
            self._answer(f"{values[0]:.5E},{values[1]:.5E},0")

    def _read_one(self, index: int) -> None:
        values = self._fresh_values()
        self._answer("ERROR" if values is None else f"{values[index]:.5E}")

    def _measure(self) -> tuple[float, float] | None:
        """Main and secondary value of the active function from the lab's coil impedance."""
        if self._code("PMOD") in (0, 10, 11):  # AUTO display and transformer modes: nothing to read
            return None
        frequency = float(self.settings["FREQ"])
        omega = 2 * math.pi * frequency
        averages = self._code("NAVG") if self.settings["AVGM"] else 1
        z = self.lab.measured_impedance(frequency, SPEED_CODES[self._code("RATE")], self.settings["VOLT"], averages)
        function = self._code("PMOD")
        if function in (6, 7, 8):  # Z-theta, Y-theta, R-X: no equivalent circuit involved
            theta = math.degrees(cmath.phase(z))
            return {6: (abs(z), theta), 7: (abs(1 / z), -theta), 8: (z.real, z.imag)}[function]
        circuit = self._code("CIRC")
        parallel = circuit == 1 or (circuit == 2 and abs(z) > 1e3)
        y = 1 / z
        if function == 9:  # G-B
            return y.real, y.imag
        resistance = (1 / y.real if y.real else math.inf) if parallel else z.real
        q = abs(z.imag) / z.real if z.real else math.inf
        if function in (1, 2, 5):  # L-Q, L-R, R-Q
            inductance = (-1 / (omega * y.imag) if y.imag else math.inf) if parallel else z.imag / omega
            return {1: (inductance, q), 2: (inductance, resistance), 5: (resistance, q)}[function]
        capacitance = y.imag / omega if parallel else (-1 / (omega * z.imag) if z.imag else math.inf)
        return (capacitance, 1 / q if q else math.inf) if function == 3 else (capacitance, resistance)  # C-D, C-R

    def _compensate(self, command: str) -> None:
        frequencies = len(FREQUENCIES_HZ) if self.settings["CALL"] == 1 else 1
        self.busy_until = max(self.lab.clock.now(), self.busy_until) + COMPENSATION_TIME_S * frequencies
        self._answer("-1" if command in self.lab.faults.bridge_error_commands else "0")
