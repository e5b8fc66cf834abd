"""GRBL 1.1 emulator: the slide controller's serial protocol over the simulated lab's slide.

Speaks what drivers/grbl.py documents (sources cited there as [G-...]): a banner when the
port opens (an Arduino resets) and after Ctrl-X, ``ok`` / ``error:N`` per line (an empty line
too), ``ALARM:N`` pushed, real-time ``? ! ~ Ctrl-X`` outside the line buffer. GRBL's own
state (settings, modal mode, feed, alarm, hold) lives here; the physical slide is the lab's.
Simplifications: one axis (X), G0/G1/G90/G91/G17/G21/G54/G94 only, no acceleration, homing
as one timed move, and the planner holds one block: a new move starts from where the slide
is. Until homed, MPos counts from where the slide stood at power-up, as on the real machine.
"""

from __future__ import annotations

import re

from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.lab import SimulatedLab

BANNER = "Grbl 1.1h ['$' for help]"
UNLOCK_PROMPT = "[MSG:'$H'|'$X' to unlock]"
BUILD_INFO = ("[VER:1.1h.20190830:]", "[OPT:V,15,128]")
HELP = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]"
#: Settings the slide uses ($N -> value): report mask, soft limits, homing, homing feed/seek,
#: pull-off, X max rate, X max travel. $110 is this slide's, the rest GRBL's documented meaning [G-IF].
DEFAULT_SETTINGS: dict[int, float] = {10: 1, 20: 1, 22: 1, 24: 25.0, 25: 500.0, 27: 1.0, 110: 1000.0, 130: 145.0}
_INTEGER_SETTINGS = (10, 20, 22)
#: GRBL waits 500 ms after printing ALARM:N [G-REP report_alarm_message].
ALARM_PAUSE_S = 0.5
#: Status-report refresh counts for WCO and Ov (busy, idle) [G-REP, G-CFG].
_WCO_REFRESH = (30, 10)
_OVR_REFRESH = (20, 10)
_LINE_BUFFER = 80
#: The G codes understood, by modal group (two of one group on a line is error:21).
_G_GROUPS = {0: "motion", 1: "motion", 90: "distance", 91: "distance", 17: "plane", 21: "units",
             54: "coordinates", 94: "feed mode"}
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)")
_COMMENT = re.compile(r"\([^)]*\)|;.*$")


class GrblEmulator(LineEmulator):
    """GRBL 1.1h on an Arduino, wired to the lab's slide (MPos = lab motor position - offset)."""

    name = "grbl"
    line_endings = b"\r\n"
    reply_termination = b"\r\n"
    realtime_bytes = b"?!~\x18"

    def __init__(self, lab: SimulatedLab) -> None:
        super().__init__(lab)
        self.settings = dict(DEFAULT_SETTINGS)
        self.offset_mm = lab.slide.position(lab.clock.now())
        self.alarm = False
        self.critical = False
        self._reset_runtime()

    def _reset_runtime(self) -> None:
        """What a reset clears: modal state, hold, homing in progress, report counters [G-MAIN]."""
        self.motion = 0
        self.absolute = True
        self.feed = 0.0
        self.rate = 0.0
        self.hold = False
        self.resume_target: float | None = None
        self.homing_until: float | None = None
        self._wco_counter = 0
        self._ovr_counter = 0

    # -- power-up and reset ------------------------------------------------------------
    def on_open(self) -> None:
        """Power-up: MPos restarts at 0 where the slide stands; locked until homed if $22=1 [G-PROT]."""
        self.lab.halt_slide()
        self.drop_pending()
        self.offset_mm = self.lab.slide.position(self.lab.clock.now())
        self.lab.slide.homed = False
        self.alarm = bool(self.settings[22])
        self.critical = False
        self._reset_runtime()
        self._banner()

    def _banner(self, delay_s: float = 0.0) -> None:
        self.reply("", delay_s)
        self.reply(BANNER, delay_s)
        if self.alarm:
            self.reply(UNLOCK_PROMPT, delay_s)

    def _soft_reset(self) -> None:
        """Ctrl-X: halt, flush, ALARM:3 (6 when homing) if it was moving, banner again [G-RT, G-ALM]."""
        now = self.lab.clock.now()
        alarm = 6 if self._homing(now) else 3 if self.lab.slide.moving(now) else 0
        self.lab.halt_slide()
        self.drop_pending()
        self.critical = False
        self._reset_runtime()
        if alarm:
            self.alarm = True
            if alarm == 6:
                self.lab.slide.homed = False
            self.reply(f"ALARM:{alarm}")
        self._banner(ALARM_PAUSE_S if alarm else 0.0)

    # -- real-time bytes ---------------------------------------------------------------
    def handle_realtime(self, char: bytes) -> None:
        now = self.lab.clock.now()
        if char == b"\x18":
            self._soft_reset()
        elif self.critical or self._homing(now):
            return  # '?' and holds are ignored while homing or in a limit alarm [G-RT]
        elif char == b"?":
            self.reply(self._status(now))
        elif char == b"!" and not self.alarm and not self.hold:
            if self.lab.slide.moving(now):
                self.resume_target = self.lab.slide.move_to_mm
                self.lab.halt_slide()
            self.hold = True
        elif char == b"~" and self.hold:
            self.hold = False
            if self.resume_target is not None:
                self.lab.start_move(self.resume_target, self.rate)
                self.resume_target = None

    def _homing(self, now: float) -> bool:
        return self.homing_until is not None and now < self.homing_until

    def _state(self, now: float) -> str:
        if self._homing(now):
            return "Home"
        if self.alarm:
            return "Alarm"
        if self.hold:
            return "Hold:0"
        return "Run" if self.lab.slide.moving(now) else "Idle"

    def _status(self, now: float) -> str:
        """``<State|MPos|Bf|FS|WCO|Ov>`` with GRBL's refresh counters for WCO and Ov [G-REP]."""
        state = self._state(now)
        busy = state not in ("Idle", "Alarm")
        x = _mm(self.lab.slide.position(now) - self.offset_mm)
        mask = int(self.settings[10])
        report = f"<{state}|{'MPos' if mask & 1 else 'WPos'}:{x},0.000,0.000"
        if mask & 2:
            report += "|Bf:15,128"
        report += f"|FS:{self.rate if state == 'Run' else 0:.0f},0"
        if self._wco_counter > 0:
            self._wco_counter -= 1
        else:
            self._wco_counter = _WCO_REFRESH[0 if busy else 1] - 1
            self._ovr_counter = self._ovr_counter or 1
            report += "|WCO:0.000,0.000,0.000"
        if self._ovr_counter > 0:
            self._ovr_counter -= 1
        else:
            self._ovr_counter = _OVR_REFRESH[0 if busy else 1] - 1
            report += "|Ov:100,100,100"
        return report + ">"

    # -- lines -------------------------------------------------------------------------
    def handle_line(self, line: str) -> None:
        """One line: comments, spaces and control characters dropped, upper-cased [G-PROT]."""
        if self.critical:
            return  # a limit alarm blocks everything but reset [G-PROT]
        text = _COMMENT.sub("", "".join(c for c in line if c.isprintable() and c != " ")).upper()
        if len(text) >= _LINE_BUFFER:
            self._answer("error:11")
            return
        if text.startswith("$"):
            self._answer(*self._system(text[1:]))
        elif self._state(self._ready_at()) == "Alarm" and text:
            self._answer("error:9")
        else:
            self._answer(*self._gcode(text))

    def _ready_at(self) -> float:
        """A line sent during homing is handled when the cycle is over."""
        return max(self.lab.clock.now(), self.homing_until or 0.0)

    def _answer(self, *lines: str) -> None:
        delay = self._ready_at() - self.lab.clock.now()
        for text in lines:
            self.reply(text, delay)

    def _system(self, command: str) -> tuple[str, ...]:
        """``$`` commands and their state rules [G-SYS system_execute_line]."""
        state = self._state(self._ready_at())
        idle = state in ("Idle", "Alarm")
        if command == "":
            return HELP, "ok"
        if command == "X":
            if not self.alarm:
                return ("ok",)
            self.alarm = False
            return "[MSG:Caution: Unlocked]", "ok"
        if command == "G":
            mode = "G90" if self.absolute else "G91"
            return f"[GC:G{self.motion} G54 G17 G21 {mode} G94 M5 M9 T0 F{self.feed:.0f} S0]", "ok"
        if command == "$":
            if state in ("Run", "Hold:0"):
                return ("error:8",)
            return *(self._format_setting(n) for n in sorted(self.settings)), "ok"
        if not idle:
            return ("error:8",)
        if command == "I":
            return *BUILD_INFO, "ok"
        if command == "H":
            return self._home()
        if "=" in command:
            return (self._store_setting(command),)
        return ("error:3",)

    def _format_setting(self, number: int) -> str:
        value = self.settings[number]
        return f"${number}={int(value)}" if number in _INTEGER_SETTINGS else f"${number}={value:.3f}"

    def _store_setting(self, command: str) -> str:
        key, _, value = command.partition("=")
        if not key.isdigit() or int(key) not in self.settings:
            return "error:3"
        if not _NUMBER.fullmatch(value):
            return "error:2"
        number, number_value = int(key), float(value)
        if number_value < 0:
            return "error:4"
        if number == 20 and number_value and not self.settings[22]:
            return "error:10"
        self.settings[number] = int(number_value) if number in _INTEGER_SETTINGS else number_value
        if number == 22 and not number_value:
            self.settings[20] = 0  # disabling homing forces soft limits off [G-SYS settings]
        return "ok"

    def _home(self) -> tuple[str, ...]:
        """Seek the switch (at true MPos 0), locate slowly, pull off to -$27 [G-LIM]; ok when done."""
        if not self.settings[22]:
            return ("error:5",)
        now = self.lab.clock.now()
        here = self.lab.slide.position(now)
        pulloff, locate, seek = self.settings[27], self.settings[24], self.settings[25]
        duration = (abs(here) + 2 * pulloff) / seek * 60.0 + pulloff / locate * 60.0
        travel = abs(-pulloff - here)
        self.lab.start_move(-pulloff, travel / duration * 60.0 if travel else 0.0)
        self.lab.slide.last_direction = -1  # the cycle ends pulling off the switch
        self.lab.slide.homed = True
        self.offset_mm = 0.0
        self.alarm = self.hold = False
        self.homing_until = now + duration
        return ("ok",)

    def _gcode(self, text: str) -> tuple[str, ...]:
        """The G-code subset: G0/G1 X F, G90/G91, and no-op G17/G21/G54/G94 [G-IF error codes]."""
        words: dict[str, float] = {}
        modal: dict[str, float] = {}
        position = 0
        while position < len(text):
            letter = text[position]
            if not letter.isalpha():
                return ("error:1",)
            number = _NUMBER.match(text, position + 1)
            if number is None:
                return ("error:2",)
            value = float(number.group())
            position = number.end()
            if letter == "G":
                group = _G_GROUPS.get(value)
                if group is None:
                    return ("error:20",)
                if group in modal:
                    return ("error:21",)
                modal[group] = value
            elif letter in ("X", "F", "N"):
                if letter in words:
                    return ("error:25",)
                words[letter] = value
            else:
                return ("error:20",)
        if words.get("F", 0.0) < 0:
            return ("error:4",)
        motion = int(modal.get("motion", self.motion))
        feed = words.get("F", self.feed)
        if "X" in words and motion == 1 and feed <= 0:
            return ("error:22",)
        self.motion = motion
        self.absolute = modal.get("distance", 90 if self.absolute else 91) == 90
        self.feed = feed
        if "X" in words:
            return self._move(words["X"], self.settings[110] if motion == 0 else min(feed, self.settings[110]))
        return ("ok",)

    def _move(self, x: float, rate: float) -> tuple[str, ...]:
        """Queue a move; a target outside [-$130, 0] is a soft-limit alarm that needs a reset [G-SYS, G-PROT]."""
        planned = self.resume_target if self.resume_target is not None else self.lab.slide.motor_mm
        target = x if self.absolute else planned - self.offset_mm + x
        if self.settings[20] and not -self.settings[130] <= target <= 0:
            self.lab.halt_slide()
            self.alarm = self.critical = True
            self.resume_target = None
            self.reply("ALARM:2")
            self.reply("[MSG:Reset to continue]", ALARM_PAUSE_S)
            return ()
        self.rate = rate
        if self.hold:
            self.resume_target = target + self.offset_mm
        else:
            self.lab.start_move(target + self.offset_mm, rate)
        return ("ok",)


def _mm(value: float) -> str:
    """Three decimals as GRBL prints positions, without a negative zero [G-REP]."""
    return f"{round(value, 3) + 0.0:.3f}"
