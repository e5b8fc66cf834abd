"""Hameg (Rohde & Schwarz) HM8118 LCR bridge over RS-232 / USB virtual COM port.

Sources (facts not in the project's issue are cited where used):
  [M32] HM8118 manual, ch. 10 "Command reference", sections 10.1-10.2, p. 32
  [M23] HM8118 manual (German), "Befehlsliste", p. 23
  [M50] HM8118 manual, s. 7.3.2 (HZ186 / compensation), p. 50
  [SWM] SweepMe! instrument-drivers, src/LCRmeter-Hameg_HM8118/main.py
  [KAK] kaktus85/Hameg8118 (C#), Global.cs / Program.cs
  [RSX] Rohde-Schwarz/Examples, RsInstrument_HM8118_Example.py
Set commands are silent when accepted [SWM, KAK]; the bridge answers ``ERROR`` to a
command it refuses [M23], so every setting is read back to confirm it [KAK does the same].
"""

from __future__ import annotations

import math
from typing import Any

from ecds_lab.drivers.instrument import Control, Instrument, in_range, integer_in_range, one_of
from ecds_lab.drivers.replies import INTEGER, NR3, Field, ReplyFormat, ask_checked, drain
from ecds_lab.instruments.interfaces import BridgeReading, BridgeSettings
from ecds_lab.transports.base import Transport

#: The 69 discrete test frequencies, 20 Hz-200 kHz ([M50] s. 7.3.2 names 69; list identical in [SWM], [KAK]).
FREQUENCIES_HZ: tuple[int, ...] = (
    20, 24, 25, 30, 36, 40, 45, 50, 60, 72, 75, 80, 90,
    100, 120, 150, 180, 200, 240, 250, 300, 360, 400, 450, 500, 600, 720, 750, 800, 900,
    1000, 1200, 1500, 1800, 2000, 2400, 2500, 3000, 3600, 4000, 4500, 5000, 6000, 7200, 7500, 8000, 9000,
    10000, 12000, 15000, 18000, 20000, 24000, 25000, 30000, 36000, 40000, 45000, 50000, 60000, 72000,
    75000, 80000, 90000, 100000, 120000, 150000, 180000, 200000,
)

#: PMOD codes: main-secondary display pairs (N-theta and M need the HZ186 transformer fixture).
FUNCTIONS = {"auto": 0, "L-Q": 1, "L-R": 2, "C-D": 3, "C-R": 4, "R-Q": 5, "Z-theta": 6, "Y-theta": 7,
             "R-X": 8, "G-B": 9, "N-theta": 10, "M": 11}
CIRCUITS = {"series": 0, "parallel": 1, "auto": 2}
SPEEDS = {"fast": 0, "medium": 1, "slow": 2}
TRIGGER_MODES = {"continuous": 0, "manual": 1, "external": 2}

#: Link settings: 9600 8N1, no handshake, CR both ways [KAK, SWM]; R&S pace 200 ms per write [RSX].
SERIAL_SETTINGS: dict[str, Any] = {
    "baudrate": 9600, "bytesize": 8, "parity": "N", "stopbits": 1,
    "write_termination": "\r", "read_termination": "\r", "timeout_s": 3.0, "min_interval_s": 0.2,
    # a refused set command answers ERROR [M23]: waiting before the read-back query, it is that command's
    # answer, not a stale line (ecds_lab/transports/base.py)
    "write_replies": ("ERROR",),
}
#: ``XALL?`` -> main,secondary,bin: both values in NR3 with a two-digit exponent, the bin number an
#: integer, 99 without the binning interface (R&S HM8118 manual, ch. 10, p. 71; the emulator:
#: ``1.23456E-04,5.83000E+01,99``; the older recorded sessions: ``...,0``). The bridge's
#: displays end at 99999 x 10^x; magnitudes beyond 1e9 (H, Ohm, F, S...) are not a reading. Asking
#: again returns the same measurement, so a garbled reply is re-queried once.
XALL_REPLY = ReplyFormat((Field("main", NR3, -1e9, 1e9), Field("secondary", NR3, -1e9, 1e9),
                          Field("bin", INTEGER, 0, 99)))

#: Upper bound of one reading at the slowest speed, to wait for averaged readings: the manual gives about
#: 1.5 readings per second at SLOW and a speed "reduced automatically" at very low test frequencies
#: (HM8118 Handbuch, "Messgeschwindigkeit", p. 12); 1.0 s leaves that reduction a margin (an assumption).
SLOWEST_READING_S = 1.0
#: A compensation over all 69 frequencies takes up to ~2 minutes without answering [KAK].
COMPENSATION_TIMEOUT_S = 180.0


class HM8118(Instrument):
    """The HM8118 as its manual's command list: one Control per command."""

    model = "HM8118"

    frequency_hz: Control[float] = Control("FREQ?", "FREQ {:.0f}", "Test frequency in Hz; only the 69 discrete values.",
                                           validator=one_of(FREQUENCIES_HZ, " Hz"))
    voltage_v: Control[float] = Control("VOLT?", "VOLT {:.3f}", "Test signal level, 0.05-1.5 V rms.",
                                        validator=in_range(0.05, 1.5, " V"))
    function: Control[str] = Control("PMOD?", "PMOD {}", "Measurement function (main-secondary pair).",
                                     mapping=FUNCTIONS, parse=int)
    circuit: Control[str] = Control("CIRC?", "CIRC {}", "Equivalent circuit: series, parallel or auto.",
                                    mapping=CIRCUITS, parse=int)
    speed: Control[str] = Control("RATE?", "RATE {}", "Measurement speed; slow is the most accurate.",
                                  mapping=SPEEDS, parse=int)
    averaging: Control[bool] = Control("AVGM?", "AVGM {}", "Averaging on (NAVG readings) or off [SWM].",
                                       mapping={False: 0, True: 1}, parse=int)
    averages: Control[int] = Control("NAVG?", "NAVG {}", "Number of readings averaged, 2-99 [SWM].",
                                     validator=integer_in_range(2, 99), parse=int)
    trigger_mode: Control[str] = Control("MMOD?", "MMOD {}", "Trigger: continuous, manual (*TRG) or external.",
                                         mapping=TRIGGER_MODES, parse=int)

    def __init__(self, transport: Transport) -> None:
        super().__init__(transport)
        self._frequency_hz: float | None = None
        self._averages = 1

    # -- error handling ([M23]: the bridge answers ERROR) ----------------------------------
    def check_reply(self, command: str, reply: str) -> None:
        if reply.strip().upper() == "ERROR":
            raise self.fail(command, reply)

    def confirm_set(self, control: Control[Any], command: str, value: Any) -> None:
        """Read the setting back: ``ERROR`` means the set was refused, another value that it was changed."""
        query = control.get_command or ""
        reply = self.transport.query(query)
        self.check_reply(command, reply)
        expected = control.encode(self, value)
        try:
            actual = control.parse(reply)
        except ValueError:  # not this setting's reply (an unsolicited line ahead of it): drain, ask once more
            drain(self)
            reply = self.transport.query(query)
            self.check_reply(command, reply)
            try:
                actual = control.parse(reply)
            except ValueError:
                raise self.fail(query, reply, f"not a {control.name} value (read back after {command!r})") from None
        if isinstance(expected, float):
            changed = not math.isclose(actual, expected, rel_tol=1e-6, abs_tol=1e-6)
        else:
            changed = actual != expected
        if changed:
            raise self.fail(command, reply, f"read back {reply!r} after setting {value!r}")

    # -- LCRBridge interface -------------------------------------------------------------
    def identity(self) -> str:
        return self.ask("*IDN?")

    def reset(self) -> None:
        self.write("*RST")
        self._frequency_hz = None

    def configure(self, settings: BridgeSettings) -> None:
        """Set function, circuit, level, speed and averaging; manual trigger (*TRG) for measurements."""
        for control, value in self._plan(settings):
            setattr(self, control, value)
        self._averages = settings.averages

    def _plan(self, settings: BridgeSettings) -> list[tuple[str, Any]]:
        """Validate every setting before the first one is sent."""
        steps: list[tuple[str, Any]] = [
            ("function", settings.function), ("circuit", settings.circuit), ("voltage_v", settings.voltage_v),
            ("speed", settings.speed), ("averaging", settings.averages > 1),
        ]
        if settings.averages > 1:
            steps.append(("averages", settings.averages))
        steps.append(("trigger_mode", "manual"))
        for name, value in steps:
            getattr(type(self), name).encode(self, value)
        return steps

    def set_frequency(self, frequency_hz: float) -> None:
        if self._frequency_hz != float(frequency_hz):
            self.frequency_hz = frequency_hz
            self._frequency_hz = float(frequency_hz)

    def measure(self) -> BridgeReading:
        """Trigger one measurement, wait for it (*WAI), read main and secondary with XALL?."""
        if self._frequency_hz is None:
            self._frequency_hz = float(self.frequency_hz)
        self.write("*TRG")
        self.write("*WAI")
        _, (main, secondary, _bin) = ask_checked(
            self, "XALL?", XALL_REPLY, timeout_s=self.transport.timeout_s + self._averages * SLOWEST_READING_S)
        return BridgeReading(main, secondary, self._frequency_hz)

    def open_compensation(self, all_frequencies: bool = False) -> None:
        """OPEN compensation (leads open) at this or all 69 frequencies; replies 0 or -1 [KAK]."""
        self._compensate("CROP", all_frequencies)

    def short_compensation(self, all_frequencies: bool = False) -> None:
        """SHORT compensation (leads shorted) at this or all 69 frequencies; replies 0 or -1 [KAK]."""
        self._compensate("CRSH", all_frequencies)

    def _compensate(self, command: str, all_frequencies: bool) -> None:
        self.write(f"CALL {1 if all_frequencies else 0}")
        reply = self.ask(command, timeout_s=max(self.transport.timeout_s, COMPENSATION_TIMEOUT_S))
        if reply.strip() != "0":
            raise self.fail(command, reply, "compensation failed")
