"""HM8118 LCR bridge emulator: the bridge's serial protocol over the simulated lab's coil.

Written from the instrument's manual, not from any driver or client (its tables are the emulator's own).
Manual pages found in the stored public copies (each fact below names the page it comes from):
  [M68]  R&S HM8118 user manual (English), ch. 10 "Command Reference", 10.1 "Setting Up the Command
         Structure", 10.2 "Supported Command and Data Formats", p. 68 of the bilingual manual:
         https://www.manualslib.de/manual/6643/Hameg-Rands-Hm8118.html?page=68 (the same text in the
         HAMEG edition: https://manualshive.com/ru/manual/hameg/hm8118/3433174?page=32)
  [D11]  HM8118 Handbuch (German), "Inbetriebnahme", p. 11 (setup memories, the nine functions):
         https://manualshive.com/en/manual/hameg/hm8118/3435322?page=11
  [D12]  same, p. 12, "Messgeschwindigkeit", "Triggerquelle / Triggerbetriebsart":
         https://manualshive.com/en/manual/hameg/hm8118/3435322?page=12
  [D23]  same, p. 23, "Befehlsliste" (XDLT?, XDMT?, XMAJ?, XMIN?) and "Befehlsliste Binning":
         https://manualshive.com/en/manual/hameg/hm8118/3435322?page=23
  [E71]  R&S HM8118 user manual (English), ch. 10 "Command Reference", p. 71 (CALL 1, CROP, CRSH, XALL?,
         XMAJ?, XMIN?, XDLT?, XDMT?): https://manualshive.com/en/manual/rohde-and-schwarz/hm8118/1477853?page=71
  [E51]  HM8118 manual (English), 6.3 "Reference Value", 6.4 "Selecting the Measurement Range", p. 51:
         https://manualshive.com/ru/manual/hameg/hm8118/3433174?page=15
  [M50]  HM8118 manual, 7.3.2, p. 50 (compensation over the 69 test frequencies)
  [SPEC] HM8118 data sheet: test frequencies 20 Hz-200 kHz, test signal 50 mV-1.5 V rms
The command list's remaining pages (the alphabetical list from *TRG to VOLT, before CALL [E71] and XDLT?
[D23]) and the interface chapter were not among the stored copies; what they would have said is marked
ASSUMED. Where the two editions differ, the English R&S edition [E71] is followed: the German one [D23] has
XDLT? fail on a zero reference too, the English one only XDMT?, the relative deviation (an absolute
deviation from zero is defined).

| What                              | Emulator                                           | Source            |
|-----------------------------------|----------------------------------------------------|-------------------|
| command syntax                    | 4-letter mnemonic, ``?`` queries, ``,`` separates  | [M68] 10.1        |
| terminator                        | CR or CR+LF ends a command, a lone LF does not     | [M68] 10.1        |
| one command at a time             | a reply waits for the measurement in progress      | [M68] 10.2        |
| ``;``-joined command strings      | accepted, each part in turn (the manual only       | [M68] 10.1 note;  |
|                                   | recommends avoiding them)                          | rest ASSUMED      |
| *IDN?                             | ``HAMEG Instruments, HM8118,<serial>,<firmware>``  | [M68] 10.2        |
| *RST                              | factory settings (values: ASSUMED, see SETTINGS)   | [M68] 10.2        |
| *OPC?                             | ``1`` once the measurement is complete             | [M68] 10.2        |
| XMAJ?, XMIN?                      | ERROR in AUTO function, and in the percent display | [D23], [E71]      |
|                                   | when the nominal (PREL) value is zero              |                   |
| XDLT?                             | absolute deviation from PREL; ERROR in AUTO        | [E71]             |
| XDMT?                             | relative deviation (percent) from PREL; ERROR in   | [E71]             |
|                                   | AUTO or when PREL is zero                          |                   |
| binning (BCLR, BING, BLIH, ...)   | ERROR: only with the HO118 interface fitted        | [D23]             |
| PREL                              | five decimals (reference entered with up to five   | [E51] 6.3         |
|                                   | digits after the point)                            |                   |
| ∆ABS / ∆% display (OUTP)          | deviation from the reference, absolute or percent  | [E51] 6.3; codes  |
|                                   |                                                    | 0/1/2 ASSUMED     |
| RNGE                              | ranges 1-6, auto ranging on every reading          | [E51] 6.4; limits |
|                                   |                                                    | per range ASSUMED |
| RNGH                              | range hold; choosing a range holds it              | [E51] 6.4 (AUTO/  |
|                                   |                                                    | HOLD); codes      |
|                                   |                                                    | ASSUMED           |
| range held, |Z| > 100x nominal    | the reading is an error (OVERRANGE on the display; | [E51] 6.4; reply  |
|                                   | ``ERROR`` over the link)                           | and nominal       |
|                                   |                                                    | ASSUMED           |
| RATE speeds                       | fast 1/14 s, medium 1/8 s, slow 0.6 s per reading  | [D12] (see below) |
| MMOD trigger modes                | continuous, manual (*TRG), external                | [D12]; codes      |
|                                   |                                                    | ASSUMED           |
| PMOD functions                    | L-Q, L-R, C-D, C-R, R-Q, Z-θ, Y-θ, N-θ, M          | [D11]; codes, and |
|                                   | (and R-X, G-B)                                     | R-X, G-B ASSUMED  |
| FREQ                              | the 69 frequencies, 20 Hz-200 kHz                  | [SPEC, M50]       |
| VOLT                              | 0.05-1.5 V rms                                     | [SPEC]            |
| AVGM, NAVG                        | off / average of NAVG 2-99 / median of three       | ASSUMED           |
| BIAS, VBIA                        | off/internal/external; internal 0-5 V              | ASSUMED           |
| LOCK                              | front panel locked out (the manual names a local   | [M68] 10 (lockout |
|                                   | lockout via the interface, not its command)        | exists); ASSUMED  |
| $STL                              | trigger delay 0-40,000 ms added to a measurement   | ASSUMED           |
| CONV                              | constant voltage on/off                            | ASSUMED           |
| CALL                              | CALL 1: the next CROP/CRSH compensates all 69      | [E71], [M50];     |
|                                   | frequencies; CALL 0 this frequency only            | code 0 ASSUMED    |
| CROP, CRSH                        | reply ``0`` (done) or ``-1`` (failed), unasked     | [E71]; 1.5 s per  |
|                                   |                                                    | frequency ASSUMED |
| set commands                      | silent when accepted, ``ERROR`` when refused       | [D23] names the   |
|                                   |                                                    | "Fehlermeldung";  |
|                                   |                                                    | text ASSUMED      |
| ``XALL?``                         | ``main,secondary,bin``; bin 99 without the HO118   | [E71]; NR3 with   |
|                                   | binning interface (this bridge has none)           | five decimals     |
|                                   |                                                    | ASSUMED           |

Timing. The manual gives readings per second under continuous trigger: "about 1.5 at SLOW, 8 at MED,
14 at FAST" [D12], i.e. 1/14 s and 1/8 s per reading, used as given; SLOW would be about 0.67 s, but the
emulator keeps 0.6 s because the run readings pinned in tests/simulators/test_pinned_readings.py were
taken with it (0.6 s is 1.7 readings per second, within "about 1.5"). The manual adds that the speed is
reduced automatically at very low test frequencies [D12] without saying by how much; not modelled.
The bridge "does not support parallel processing of commands" [M68] but names no time to take in a
command: ASSUMED ``COMMAND_TIME_S`` = 0.1 s, a line that arrives sooner after the previous one being lost.

Bias, constant-voltage mode and the range setting are held and read back but do not change the lab's
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
#: ``VBIA``: internal DC bias in V (ASSUMED: no stored manual page gives it).
BIAS_VOLTAGE_RANGE_V = (0.0, 5.0)
#: ``$STL``: trigger delay in ms (ASSUMED: 0-40 s, sent in ms).
TRIGGER_DELAY_RANGE_MS = (0, 40_000)
#: ``PMOD`` codes: the main-secondary display pairs; the nine of [D11] (N-theta and M for transformers, with
#: the HZ186 fixture) plus R-X and G-B; the code numbers are ASSUMED.
FUNCTION_CODES = {0: "AUTO", 1: "L-Q", 2: "L-R", 3: "C-D", 4: "C-R", 5: "R-Q", 6: "Z-theta", 7: "Y-theta",
                  8: "R-X", 9: "G-B", 10: "N-theta", 11: "M"}
#: ``CIRC`` codes (ASSUMED).
CIRCUIT_CODES = {0: "series", 1: "parallel", 2: "auto"}
#: ``RATE`` codes: the three speeds of [D12] (codes ASSUMED), named as the lab's noise model names them.
SPEED_CODES = {0: "fast", 1: "medium", 2: "slow"}
#: ``MMOD`` codes: the trigger modes CONT, MAN, EXT of [D12] (codes ASSUMED).
TRIGGER_CODES = {0: "continuous", 1: "manual", 2: "external"}
#: ``AVGM`` codes: off, average over NAVG readings, median of three (all ASSUMED).
AVERAGING_CODES = {0: "off", 1: "average", 2: "median"}
MEDIAN_READINGS = 3
#: ``NAVG``: readings averaged when ``AVGM 1`` (ASSUMED).
AVERAGES_RANGE = (2, 99)
#: ``XALL?``'s sorting bin without the binning interface fitted (or for an invalid measurement) [E71].
NO_BIN = 99
#: ``BIAS`` codes (ASSUMED).
BIAS_CODES = {0: "off", 1: "internal", 2: "external"}
#: ``OUTP`` codes: the value, or its deviation from the reference as ∆ABS or ∆% [E51] (codes ASSUMED).
OUTPUT_CODES = {0: "value", 1: "deviation", 2: "percent"}
#: ``RNGE`` codes 1-6 [E51] and the upper |Z| each range serves when auto-ranging (limits ASSUMED).
RANGE_LIMITS_OHM = {1: 3.0, 2: 25.0, 3: 400.0, 4: 6.4e3, 5: 100e3, 6: math.inf}
_RANGES = tuple(RANGE_LIMITS_OHM.items())  # (code, limit) in ascending order, walked on every reading
#: With the range held, a component whose impedance exceeds this many times the range's nominal value reads
#: OVERRANGE [E51 6.4]; the nominal value is taken as the range's auto-ranging limit (ASSUMED).
OVERRANGE_FACTOR = 100.0
#: Time of one reading per ``RATE`` code: 14 and 8 readings per second at FAST and MED [D12]; SLOW kept at
#: 0.6 s (the manual's "about 1.5 per second" would be 0.67 s; see the module docstring).
MEASUREMENT_TIME_S = {0: 1 / 14, 1: 1 / 8, 2: 0.6}
COMPENSATION_TIME_S = 1.5  # per frequency (ASSUMED)
#: Time the bridge needs to take in one command line; a line arriving sooner is lost (ASSUMED, see above).
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


#: The remote command list's settings: ``NAME value`` sets, ``NAME?`` reads back [M68 10.1]. Defaults are
#: the *RST state (ASSUMED: 1 kHz, 1 V, auto function/circuit, medium speed, everything else off).
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
    #: CR ends a command; the LF of a CR+LF is dropped, a lone LF ends nothing [M68 10.1].
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
        """Replies wait until the measurement in progress is done (no parallel processing [M68 10.2]; reply()
        takes a finished measurement's negative delay as none)."""
        self.reply_at(text, self.busy_until)

    def _handle(self, command: str) -> None:
        if "\n" in command:  # a lone LF is no terminator: the line is garbled [M68 10.1]
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

        A percent display with a zero reference has nothing to show: an error [D23 XMAJ?]."""
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
            self._answer(f"{values[0]:.5E},{values[1]:.5E},{NO_BIN}")

    def _read_one(self, index: int) -> None:
        values = self._displayed()
        self._answer("ERROR" if values is None else f"{values[index]:.5E}")

    def _read_deviation(self, percent: bool) -> None:
        """XDLT? / XDMT?: main value minus the PREL reference, absolute or relative (percent); the relative one is
        an error when the reference is zero [E71]."""
        values = self._fresh_values()
        reference = self.settings["PREL"]
        if values is None or (percent and reference == 0):
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
        if function in (0, 10, 11):  # AUTO: an error [D23]; transformer modes need the HZ186: nothing to read
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
        elif magnitude > OVERRANGE_FACTOR * RANGE_LIMITS_OHM[self._code("RNGE")]:
            return None  # OVERRANGE [E51 6.4]: a held range far below the component
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
