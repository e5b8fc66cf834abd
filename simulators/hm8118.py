"""HM8118 LCR bridge emulator: the bridge's serial protocol over the simulated lab's coil.

Written from the instrument's manual, not from the driver (its tables are the emulator's own):
  [M32]  HM8118 manual (English), ch. 10 "Command Reference", 10.1 "Setting Up the Command
         Structure" and 10.2 "Supported Command and Data Formats", p. 32: four-letter mnemonics,
         ``(?)`` marks a command that can also be queried; every command ends with CR or CR+LF,
         "no individual LF"; the bridge "does not support parallel processing of commands";
         *IDN? format, *RST to factory settings, *OPC? answers 1 once the measurement is complete
  [M23]  HM8118 manual (German), "Befehlsliste", p. 23: XMAJ?, XMIN?, XDLT?, XDMT? (the deviation
         from the PREL reference), an error message when nothing can be read (AUTO function, a
         zero reference); the binning commands (BCLR, BING, BLIH, ...) exist only with the HO118
         binning interface fitted
  [M50]  HM8118 manual, s. 7.3.2, p. 50 (compensation over the 69 test frequencies)
  [SPEC] HM8118 data sheet: test frequencies 20 Hz-200 kHz, test signal 50 mV-1.5 V rms
  [SWM]  SweepMe! instrument-drivers, LCRmeter-Hameg_HM8118 (a third-party client whose set commands
         the bridge accepts silently): LOCK 0|1, RNGH 0 (auto range), OUTP 0 (plain values), BIAS
         0|1|2 (off, internal, external bias), VBIA 0-5 V and VBIA?, $STL trigger delay in ms (0-40 s),
         AVGM 1 + NAVG 2-99, MMOD 0|1|2, "*TRG; *OPC?" in one line, 0.15 s between commands
  [KAK]  kaktus85/Hameg8118: CROP / CRSH answer 0 (done) or -1 (failed) after the compensation
Set commands are silent when accepted; anything refused is answered ``ERROR`` [M23].
``XALL?`` -> ``main,secondary,bin``.

Timing (assumptions where no source gives figures): fast 70 ms, medium 190 ms, slow 600 ms per
reading; the bridge needs ``COMMAND_TIME_S`` to take in one command line, and a line that arrives
sooner after the previous one is lost (it "does not support parallel processing" [M32]); 0.1 s is
below the 0.15 s [SWM] and 0.2 s (R&S example) that clients use successfully.

Re-sourcing (issue 24 point 10): of the manual's chapter 10 the stored public pages hold only its first page
(p. 32: 10.1 and 10.2, cited above as [M32]); searches for the command list that follows it (queries on XALL?,
CROP, CRSH, LOCK, RNGH, BIAS, VBIA, AVGM, NAVG, *TRG) found no further page. So LOCK, RNGH, OUTP, BIAS, VBIA,
$STL and AVGM/NAVG, their ranges, and the 0.1 s command time stay as given by [SWM] and the assumptions
below, and are marked so wherever they are used; they are not confirmed by the manual.

Assumptions, not confirmed from the manual pages at hand: the range codes of RNGE (1-6, auto-ranging
chooses by |Z|), AVGM 2 = median of three readings (the front panel's MED averaging), the OUTP codes
0 value, 1 absolute deviation, 2 percent deviation from PREL (the XDLT?/XDMT? pair [M23]; XMAJ? and
XALL? show the main value that way, and a percent display with a zero reference is an error [M23]),
CONV 0|1. Bias,
constant-voltage mode and the range setting are held and read back but do not change the lab's
coil: the lab's noise model is given the set test level in every mode.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable
from dataclasses import dataclass

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
#: ``VBIA``: internal DC bias in V [SWM].
BIAS_VOLTAGE_RANGE_V = (0.0, 5.0)
#: ``$STL``: trigger delay in ms [SWM: 0-40 s, sent in ms].
TRIGGER_DELAY_RANGE_MS = (0, 40_000)
#: ``PMOD`` codes [M32]: the main-secondary display pair (10 and 11 need the HZ186 fixture).
FUNCTION_CODES = {0: "AUTO", 1: "L-Q", 2: "L-R", 3: "C-D", 4: "C-R", 5: "R-Q", 6: "Z-theta", 7: "Y-theta",
                  8: "R-X", 9: "G-B", 10: "N-theta", 11: "M"}
#: ``CIRC`` codes [M32].
CIRCUIT_CODES = {0: "series", 1: "parallel", 2: "auto"}
#: ``RATE`` codes [M32], named as the lab's noise model names them.
SPEED_CODES = {0: "fast", 1: "medium", 2: "slow"}
#: ``MMOD`` codes [M32, SWM].
TRIGGER_CODES = {0: "continuous", 1: "manual", 2: "external"}
#: ``AVGM`` codes: off, average over NAVG readings [SWM], median (assumption, see above).
AVERAGING_CODES = {0: "off", 1: "average", 2: "median"}
MEDIAN_READINGS = 3
#: ``NAVG``: readings averaged when ``AVGM 1`` [SWM].
AVERAGES_RANGE = (2, 99)
#: ``BIAS`` codes [SWM].
BIAS_CODES = {0: "off", 1: "internal", 2: "external"}
#: ``OUTP`` codes (assumption, see above).
OUTPUT_CODES = {0: "value", 1: "deviation", 2: "percent"}
#: ``RNGE`` codes and the upper |Z| each range serves when auto-ranging (assumption, see above).
RANGE_LIMITS_OHM = {1: 3.0, 2: 25.0, 3: 400.0, 4: 6.4e3, 5: 100e3, 6: math.inf}
_RANGES = tuple(RANGE_LIMITS_OHM.items())  # (code, limit) in ascending order, walked on every reading
MEASUREMENT_TIME_S = {0: 0.07, 1: 0.19, 2: 0.6}
COMPENSATION_TIME_S = 1.5  # per frequency
#: Time the bridge needs to take in one command line; a line arriving sooner is lost (see above).
COMMAND_TIME_S = 0.1


@dataclass(frozen=True)
class Setting:
    """One settable value of the remote command list: its check and its reply format."""

    valid: Callable[[float], bool]
    default: float
    decimals: int = 0


def _codes(table: dict[int, str]) -> Callable[[float], bool]:
    return lambda value: value in table


def _within(low: float, high: float, whole: bool = False) -> Callable[[float], bool]:
    return lambda value: low <= value <= high and (value.is_integer() or not whole)


#: The remote command list's settings: ``NAME value`` sets, ``NAME?`` reads back [M32, SWM]. Defaults are
#: the *RST state (assumption: 1 kHz, 1 V, auto function/circuit, medium speed, everything else off).
SETTINGS: dict[str, Setting] = {
    "FREQ": Setting(lambda value: value in FREQUENCIES_HZ, 1000),
    "VOLT": Setting(_within(*VOLTAGE_RANGE_V), 1.0, decimals=3),
    "PMOD": Setting(_codes(FUNCTION_CODES), 0),
    "CIRC": Setting(_codes(CIRCUIT_CODES), 2),
    "RATE": Setting(_codes(SPEED_CODES), 1),
    "AVGM": Setting(_codes(AVERAGING_CODES), 0),
    "NAVG": Setting(_within(*AVERAGES_RANGE, whole=True), 2),
    "MMOD": Setting(_codes(TRIGGER_CODES), 0),
    "CALL": Setting(_codes({0: "this frequency", 1: "all frequencies"}), 0),
    "RNGE": Setting(_codes(dict.fromkeys(RANGE_LIMITS_OHM, "")), 3),
    "RNGH": Setting(_codes({0: "auto", 1: "hold"}), 0),
    "CONV": Setting(_codes({0: "off", 1: "on"}), 0),
    "BIAS": Setting(_codes(BIAS_CODES), 0),
    "VBIA": Setting(_within(*BIAS_VOLTAGE_RANGE_V), 0.0, decimals=3),
    "OUTP": Setting(_codes(OUTPUT_CODES), 0),
    "PREL": Setting(lambda value: math.isfinite(value), 0.0, decimals=5),
    "LOCK": Setting(_codes({0: "front panel free", 1: "front panel locked"}), 0),
    "$STL": Setting(_within(*TRIGGER_DELAY_RANGE_MS, whole=True), 0),
}


class HM8118Emulator(LineEmulator):
    name = "hm8118"
    #: CR ends a command; the LF of a CR+LF is dropped, a lone LF ends nothing [M32].
    line_endings = b"\r"
    reply_termination = b"\r"

    def __init__(self, lab: SimulatedLab) -> None:
        super().__init__(lab)
        self._commands: dict[str, Callable[[], None]] = {
            "*IDN?": lambda: self._answer(IDENTITY),
            "*RST": self.reset,
            "*OPC?": lambda: self._answer("1"),
            "*WAI": lambda: None,
            "*TRG": self._trigger,
            "XALL?": self._read_all,
            "XMAJ?": lambda: self._read_one(0),
            "XMIN?": lambda: self._read_one(1),
            "XDLT?": lambda: self._read_deviation(percent=False),
            "XDMT?": lambda: self._read_deviation(percent=True),
            "CROP": lambda: self._compensate("CROP"),
            "CRSH": lambda: self._compensate("CRSH"),
        }
        self._last_line_at: float | None = None
        #: Lines lost because they came sooner than COMMAND_TIME_S after the previous one.
        self.lost_lines: list[str] = []
        self.reset()

    def reset(self) -> None:
        self.settings: dict[str, float] = {name: setting.default for name, setting in SETTINGS.items()}
        self.busy_until = self.lab.clock.now()
        self.last_values: tuple[float, float] | None = None

    # -- protocol --------------------------------------------------------------------------
    def handle_line(self, line: str) -> None:
        if line.startswith("\n"):  # the LF of a CR+LF
            line = line[1:]
        now = self.lab.clock.now()
        if self.paced_host and self._last_line_at is not None and now - self._last_line_at < COMMAND_TIME_S:
            self.lost_lines.append(line)
            return
        self._last_line_at = now
        handler = self._commands.get(line)
        if handler is not None and not self.lab.faults.bridge_error_commands:
            handler()  # the usual line: one listed command exactly as the table writes it, no refusal injected
            return
        for command in line.split(";") if ";" in line else (line,):
            command = command.strip(" ")
            if command:
                self._handle(command)

    def _answer(self, text: str) -> None:
        """Replies wait until the measurement in progress is done (one command at a time; reply() takes a
        finished measurement's negative delay as none)."""
        self.reply(text, self.busy_until - self.lab.clock.now())

    def _handle(self, command: str) -> None:
        if "\n" in command:  # a lone LF is no terminator: the line is garbled [M32]
            self._answer("ERROR")
            return
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
        elif mnemonic.endswith("?") and mnemonic[:-1] in SETTINGS and not argument:
            self._answer(self._format_setting(mnemonic[:-1]))
        elif mnemonic in SETTINGS and argument:
            self._set(mnemonic, argument)
        else:
            self._answer("ERROR")

    def _set(self, mnemonic: str, argument: str) -> None:
        try:
            value = float(argument)
        except ValueError:
            self._answer("ERROR")
            return
        setting = SETTINGS[mnemonic]
        if not setting.valid(value):
            self._answer("ERROR")
            return
        self.settings[mnemonic] = round(value, setting.decimals) if setting.decimals else int(value)
        if mnemonic == "RNGE":  # choosing a range holds it
            self.settings["RNGH"] = 1

    def _format_setting(self, mnemonic: str) -> str:
        value = self.settings[mnemonic]
        decimals = SETTINGS[mnemonic].decimals
        return f"{value:.{decimals}f}" if decimals else str(int(value))

    def _code(self, mnemonic: str) -> int:
        """A coded setting (PMOD, CIRC, RATE, NAVG, ...) as the integer the bridge holds."""
        return int(self.settings[mnemonic])

    # -- measuring -------------------------------------------------------------------------
    def _readings(self) -> int:
        """Readings behind one displayed value: 1, NAVG averaged, or the median of three."""
        averaging = self._code("AVGM")
        return 1 if averaging == 0 else self._code("NAVG") if averaging == 1 else MEDIAN_READINGS

    def _duration(self, readings: int) -> float:
        """Measuring time of a value made of ``readings`` readings, plus the trigger delay ($STL)."""
        return MEASUREMENT_TIME_S[self._code("RATE")] * readings + self._code("$STL") / 1000

    def _trigger(self) -> None:
        """*TRG starts a measurement; the lab is sampled now, the result is ready after the measuring time."""
        start = max(self.lab.clock.now(), self.busy_until)
        readings = self._readings()  # found once: the measurement and its duration both depend on it
        self.last_values = self._measure(readings)
        self.busy_until = start + self._duration(readings)

    def _fresh_values(self) -> tuple[float, float] | None:
        if self.settings["MMOD"] == 0:  # continuous: always a current reading
            self._trigger()
        return self.last_values

    def _displayed(self) -> tuple[float, float] | None:
        """The displayed pair: the main value as OUTP shows it (value, deviation from PREL, or percent).

        A percent display with a zero reference has nothing to show: an error [M23 XMAJ?]."""
        values = self._fresh_values()
        if values is None:
            return None
        output, reference = self._code("OUTP"), self.settings["PREL"]
        if output == 0:
            return values
        if output == 2 and reference == 0:
            return None
        deviation = values[0] - reference
        return (100 * deviation / reference if output == 2 else deviation), values[1]

    def _read_all(self) -> None:
        values = self._displayed()
        if values is None:
            self._answer("ERROR")
        else:
            self._answer(f"{values[0]:.5E},{values[1]:.5E},0")

    def _read_one(self, index: int) -> None:
        values = self._displayed()
        self._answer("ERROR" if values is None else f"{values[index]:.5E}")

    def _read_deviation(self, percent: bool) -> None:
        """XDLT? / XDMT?: main value minus the PREL reference; an error when the reference is zero [M23]."""
        values = self._fresh_values()
        reference = self.settings["PREL"]
        if values is None or reference == 0:
            self._answer("ERROR")
            return
        deviation = values[0] - reference
        self._answer(f"{(100 * deviation / reference if percent else deviation):.5E}")

    def auto_range(self, impedance_ohm: float) -> int:
        """The range auto-ranging picks for |Z| (the lowest whose limit covers it)."""
        for code, limit in _RANGES:
            if impedance_ohm <= limit:
                return code
        raise ValueError(f"|Z| = {impedance_ohm!r} Ohm is in no range")  # NaN: the last limit is infinite

    def _measure(self, readings: int) -> tuple[float, float] | None:
        """Main and secondary value of the active function from the lab's coil impedance (``readings`` averaged)."""
        settings = self.settings
        function = self._code("PMOD")
        if function in (0, 10, 11):  # AUTO display and transformer modes: nothing to read
            return None
        frequency = float(settings["FREQ"])
        omega = 2 * math.pi * frequency
        speed, level = SPEED_CODES[self._code("RATE")], settings["VOLT"]
        if self._code("AVGM") == 2:
            samples = sorted((self.lab.measured_impedance(frequency, speed, level) for _ in range(MEDIAN_READINGS)),
                             key=abs)
            z = samples[MEDIAN_READINGS // 2]
        else:
            z = self.lab.measured_impedance(frequency, speed, level, readings)
        magnitude = abs(z)
        if not settings["RNGH"]:
            settings["RNGE"] = self.auto_range(magnitude)
        if function in (6, 7, 8):  # Z-theta, Y-theta, R-X: no equivalent circuit involved
            theta = math.degrees(cmath.phase(z))
            return {6: (magnitude, theta), 7: (abs(1 / z), -theta), 8: (z.real, z.imag)}[function]
        circuit = self._code("CIRC")
        parallel = circuit == 1 or (circuit == 2 and magnitude > 1e3)
        y = 1 / z
        if function == 9:  # G-B
            return y.real, y.imag
        resistance = (1 / y.real if y.real else math.inf) if parallel else z.real
        q = abs(z.imag) / z.real if z.real else math.inf
        if function in (1, 2, 5):  # L-Q, L-R, R-Q
            inductance = (-1 / (omega * y.imag) if y.imag else math.inf) if parallel else z.imag / omega
            return (inductance, q) if function == 1 else (inductance, resistance) if function == 2 else (resistance, q)
        capacitance = y.imag / omega if parallel else (-1 / (omega * z.imag) if z.imag else math.inf)
        return (capacitance, 1 / q if q else math.inf) if function == 3 else (capacitance, resistance)  # C-D, C-R

    def _compensate(self, command: str) -> None:
        frequencies = len(FREQUENCIES_HZ) if self.settings["CALL"] == 1 else 1
        self.busy_until = max(self.lab.clock.now(), self.busy_until) + COMPENSATION_TIME_S * frequencies
        self._answer("-1" if command in self.lab.faults.bridge_error_commands else "0")
