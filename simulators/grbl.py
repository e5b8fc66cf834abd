"""GRBL 1.1h emulator: the slide controller's firmware as seen from its serial port.

Written from the firmware sources and docs of gnea/grbl (keys as in drivers/grbl.py):
  [G-PROT] grbl/protocol.c   main loop, real-time execution, feed hold, critical alarms
  [G-MC]   grbl/motion_control.c   mc_line (planner full), mc_dwell, mc_homing_cycle, mc_reset
  [G-LIM]  grbl/limits.c   limits_go_home, limits_soft_check
  [G-SYS]  grbl/system.c   system_execute_line ($ commands and the states they need)
  [G-REP]  grbl/report.c   every printed line; report_alarm_message waits 500 ms
  [G-MAIN] grbl/main.c   what a reset re-initialises, the banner
  [G-CFG]  grbl/config.h   HOMING_CYCLE_0/1, N_HOMING_LOCATE_CYCLE, BLOCK_BUFFER_SIZE
  [G-DEF]  grbl/defaults.h   DEFAULTS_GENERIC, the stock $ settings
  [G-GC]   grbl/gcode.c   the G-code parser's error checks
  [G-IF]   doc/markdown/interface.md, commands.md, settings.md

What it reproduces: the banner only after the bootloader (an Arduino resets when the port opens);
``ok`` when a line is *planned*, with up to 15 moves queued (a full planner holds the line back);
trapezoidal moves at $120 acceleration (``FS:`` ramps); ``!`` decelerates (``Hold:1``) before the
hold is complete (``Hold:0``), ``~`` is honoured only then, and lines sent during a hold wait in the
serial buffer until after the resume (during the deceleration, Hold:1, they are still planned and
answered: sys.suspend is set only when the hold completes); a soft limit stops, prints ``ALARM:2`` and, 500 ms later,
``[MSG:Reset to continue]``, discarding any Ctrl-X that came meanwhile, and the offending line's
``ok`` comes after the accepted reset, before the banner; ``?`` during homing is answered after the
cycle; the stock homing cycle (Z first, then X and Y) fails with ``ALARM:9`` on a slide that has a
switch on X only, unless the emulator is "built" with ``homing_cycles=("X",)``.

Simplifications (documented, not hidden): the lab's slide moves linearly over each block's duration
(the ramped MPos and FS are the emulator's own), junction speeds are zero (every block starts and
ends at rest), homing runs as one timed move with no acceleration, no hard limits, probing, jogging,
arcs, overrides, coolant or spindle hardware; only the X axis has a limit switch (the slide's).
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, field

from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.lab import SimulatedLab

BANNER = "Grbl 1.1h ['$' for help]"
UNLOCK_PROMPT = "[MSG:'$H'|'$X' to unlock]"
RESET_PROMPT = "[MSG:Reset to continue]"
BUILD_INFO = ("[VER:1.1h.20190830:]", "[OPT:V,15,128]")
HELP = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]"

#: The 34 settings with the stock DEFAULTS_GENERIC values [G-DEF], in the order $$ prints them [G-REP].
STOCK_SETTINGS: dict[int, float] = {
    0: 10, 1: 25, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 10: 1, 11: 0.010, 12: 0.002, 13: 0,
    20: 0, 21: 0, 22: 0, 23: 0, 24: 25.0, 25: 500.0, 26: 250, 27: 1.0, 30: 1000, 31: 0, 32: 0,
    100: 250.0, 101: 250.0, 102: 250.0, 110: 500.0, 111: 500.0, 112: 500.0,
    120: 10.0, 121: 10.0, 122: 10.0, 130: 200.0, 131: 200.0, 132: 200.0,
}
#: The slide's EEPROM on top of the stock values: soft limits and homing on, X rate and travel.
SLIDE_SETTINGS: dict[int, float] = {20: 1, 22: 1, 110: 1000.0, 130: 145.0}
#: Settings printed as integers (uint8/uint16, rpm with 0 decimals) [G-REP report_grbl_settings].
_INTEGER_SETTINGS = frozenset({0, 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 26, 30, 31, 32})
#: The stock homing cycles [G-CFG HOMING_CYCLE_0 (1<<Z_AXIS), HOMING_CYCLE_1 ((1<<X_AXIS)|(1<<Y_AXIS))].
STOCK_HOMING_CYCLES: tuple[str, ...] = ("Z", "XY")
#: A one-switch slide's build: HOMING_CYCLE_0 (1<<X_AXIS) and no further cycle [G-CFG].
X_ONLY_HOMING_CYCLES: tuple[str, ...] = ("X",)
#: Axes with a limit switch on this machine: the slide has one, on X.
SWITCHED_AXES = "X"
#: report_alarm_message() waits this long after printing ALARM:N [G-REP].
ALARM_PAUSE_S = 0.5
#: Typical time from DTR (port open) to the banner: Arduino reset plus the bootloader's wait.
BOOT_DELAY_S = 1.5
#: HOMING_AXIS_SEARCH_SCALAR: the search covers 1.5x max travel [G-LIM].
_SEARCH_SCALAR = 1.5
#: BLOCK_BUFFER_SIZE 16 keeps one slot free: 15 planned moves [G-CFG, planner.h].
PLANNER_BLOCKS = 15
_RX_BUFFER = 128
#: LINE_BUFFER_SIZE 80: at 79 characters the line overflows [G-PROT].
_LINE_LIMIT = 79
_WCO_REFRESH = (30, 10)
_OVR_REFRESH = (20, 10)
_AXES = "XYZ"
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)")
#: Supported G codes -> modal group name [G-GC]; G4 and G53 are both non-modal (group 0).
_G_GROUPS = {0: "motion", 1: "motion", 4: "non-modal", 53: "non-modal", 17: "plane", 20: "units",
             21: "units", 90: "distance", 91: "distance", 54: "coordinates", 94: "feed mode"}
_M_GROUPS = {3: "spindle", 4: "spindle", 5: "spindle", 8: "coolant", 9: "coolant"}
_VALUE_WORDS = "FNPST"


@dataclass
class _Segment:
    """One trapezoidal move along a straight line: from rest (or ``v0``, a hold) to rest.

    A segment is never changed once made, so its phases are worked out once, when it is made
    (the status report and the event loop ask for them on every touch).
    """

    start: tuple[float, float, float]
    unit: tuple[float, float, float]
    length: float
    v0: float
    vmax: float
    accel: float
    t0: float
    #: Peak speed and the durations of acceleration, cruise and deceleration (``phases``).
    v_peak: float = field(init=False)
    up: float = field(init=False)
    cruise: float = field(init=False)
    down: float = field(init=False)
    #: When the move ends (rest at the end point).
    end: float = field(init=False)

    def __post_init__(self) -> None:
        self.v_peak, self.up, self.cruise, self.down = self.phases()
        self.end = self.t0 + self.up + self.cruise + self.down

    def phases(self) -> tuple[float, float, float, float]:
        """Peak speed and the durations of acceleration, cruise and deceleration."""
        a, v0, length = self.accel, self.v0, self.length
        v_peak = self.vmax
        d_up, d_down = (v_peak ** 2 - v0 ** 2) / (2 * a), v_peak ** 2 / (2 * a)
        if d_up + d_down > length:
            v_peak = max(v0, math.sqrt((2 * a * length + v0 ** 2) / 2))
            d_up, d_down = (v_peak ** 2 - v0 ** 2) / (2 * a), v_peak ** 2 / (2 * a)
        cruise = max(0.0, length - d_up - d_down) / v_peak if v_peak > 0 else 0.0
        return v_peak, (v_peak - v0) / a, cruise, v_peak / a

    def at(self, t: float) -> tuple[float, float]:
        """Distance travelled and speed (mm, mm/s) at time ``t``."""
        v_peak, up, cruise, down = self.v_peak, self.up, self.cruise, self.down
        a, tau = self.accel, min(max(t - self.t0, 0.0), up + cruise + down)
        if tau <= up:
            return self.v0 * tau + a * tau ** 2 / 2, self.v0 + a * tau
        s_up = (v_peak ** 2 - self.v0 ** 2) / (2 * a)
        if tau <= up + cruise:
            return s_up + v_peak * (tau - up), v_peak
        rest = tau - up - cruise
        return min(self.length, s_up + v_peak * cruise + v_peak * rest - a * rest ** 2 / 2), max(0.0, v_peak - a * rest)

    def point(self, t: float) -> tuple[float, float, float]:
        s, _ = self.at(t)
        x, y, z = (p + u * s for p, u in zip(self.start, self.unit, strict=True))
        return x, y, z


@dataclass
class _Block:
    """A planned line move: target (machine frame, mm) and the requested rate (mm/min)."""

    target: tuple[float, float, float]
    rate: float


@dataclass
class _Homing:
    """A homing cycle in progress: when it ends, whether it fails, where each axis ends up."""

    end: float
    fails: bool
    final: tuple[float, float, float]


@dataclass
class _Firmware:
    """GRBL's runtime state (what a reset or power-up re-initialises, plus the position counter)."""

    t: float = 0.0
    state: str = "Idle"  # Idle Run Hold Home Alarm Check Sleep
    hold_complete: bool = False
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    seg: _Segment | None = None
    blocks: list[_Block] = field(default_factory=list)
    planned: tuple[float, float, float] = (0.0, 0.0, 0.0)
    pending: list[str] = field(default_factory=list)
    executing: str | None = None  # a line started but not finished: its "ok" prints even on reset
    busy_until: float | None = None  # G4 dwell
    homing: _Homing | None = None
    soft_limit_stop: bool = False
    critical: bool = False
    reset_from: float = 0.0
    deaf_until: float = 0.0  # booting, or printing an alarm before a reset: input is lost
    status_deferred: bool = False
    motion: int = 0
    absolute: bool = True
    inches: bool = False
    feed: float = 0.0
    wco_counter: int = 0
    ovr_counter: int = 0


class GrblEmulator(LineEmulator):
    """GRBL 1.1h on an Arduino, wired to the lab's slide (X MPos = lab motor position - offset).

    Options (set on the instance before the port opens): ``homing_cycles`` (the build's
    HOMING_CYCLE_n axis groups; the lab's slide is built X-only, ``STOCK_HOMING_CYCLES`` is the
    release), ``boot_delay_s`` (DTR to banner), ``settings`` (the EEPROM).
    """

    name = "grbl"
    line_endings = b"\r\n"
    reply_termination = b"\r\n"
    realtime_bytes = b"?!~\x18"

    def __init__(self, lab: SimulatedLab) -> None:
        super().__init__(lab)
        self.settings: dict[int, float] = {**STOCK_SETTINGS, **SLIDE_SETTINGS}
        self.homing_cycles: tuple[str, ...] = X_ONLY_HOMING_CYCLES
        self.boot_delay_s = BOOT_DELAY_S
        self.startup_lines = ["", ""]
        self.offset: tuple[float, float, float] = (lab.slide.position(lab.clock.now()), 0.0, 0.0)
        self.fw = _Firmware(t=lab.clock.now(), pos=self.offset, planned=self.offset)
        self._dry_first: float | None = None
        self._dry = False

    # -- time: events happen at their own simulated time, when the emulator is next touched ----
    def receive(self, data: bytes) -> None:
        now = self.lab.clock.now()
        self._advance(now)
        if now < self.fw.deaf_until:
            if self.wire is not None:
                self.wire += data
            return  # the bootloader, or a reset in progress, drops what arrives [G-MAIN]
        super().receive(data)
        self._drain(now)

    def take_ready(self) -> bytes:
        self._advance(self.lab.clock.now())
        return super().take_ready()

    def next_reply_time(self) -> float | None:
        """The earliest reply: already queued, or the next one the firmware will print unprompted."""
        queued = super().next_reply_time()
        saved = copy.deepcopy((self.fw, self.offset, self.settings, self.startup_lines))
        self._dry, self._dry_first = True, None
        try:
            limit = queued if queued is not None else math.inf
            while self._dry_first is None and self._step(limit):
                pass
            found = self._dry_first
        finally:
            (self.fw, self.offset, self.settings, self.startup_lines), self._dry = saved, False
        candidates = [t for t in (queued, found) if t is not None]
        return min(candidates) if candidates else None

    def _advance(self, now: float) -> None:
        while self._step(now):
            pass
        self.fw.t = max(self.fw.t, now)

    def _step(self, limit: float) -> bool:
        """Run the next firmware event due by ``limit``; False when there is none."""
        fw = self.fw
        if fw.seg is None and fw.homing is None and fw.busy_until is None:
            return False  # nothing in progress (the usual case between moves)
        times = [
            fw.seg.end if fw.seg is not None else math.inf,
            fw.homing.end if fw.homing is not None else math.inf,
            fw.busy_until if fw.busy_until is not None else math.inf,
        ]
        t = min(times)
        if t > limit or t == math.inf:
            return False
        fw.t = max(fw.t, t)
        which = times.index(t)
        if which == 0:
            self._segment_done(t)
        elif which == 1:
            self._homing_done(t)
        else:
            fw.busy_until, fw.executing = None, None
            self._emit("ok", t)
        self._drain(t)
        return True

    def _emit(self, text: str, at: float) -> None:
        if self._dry:
            self._dry_first = at if self._dry_first is None else min(self._dry_first, at)
        else:
            self.reply_at(text, at)  # lines due at one instant share it, so they keep their order

    # -- power-up and reset ------------------------------------------------------------------
    def on_open(self) -> None:
        """DTR resets the Arduino: output lost, position counter zeroed, banner after the bootloader."""
        now = self.lab.clock.now()
        self._advance(now)
        self._halt_slide()
        self.drop_pending()
        here = self.lab.slide.position(now)
        self.offset = (here, self.fw.pos[1], self.fw.pos[2])
        self.lab.slide.homed = False
        locked = bool(self.settings[22])  # HOMING_INIT_LOCK [G-CFG, G-MAIN]
        self.fw = _Firmware(t=now, state="Alarm" if locked else "Idle", pos=self.offset, planned=self.offset,
                            deaf_until=now + self.boot_delay_s)
        self._banner(now + self.boot_delay_s)

    def _banner(self, at: float) -> None:
        """"\\r\\nGrbl 1.1h ['$' for help]" [G-REP report_init_message], then the alarm lock or startup lines."""
        self._emit("", at)
        self._emit(BANNER, at)
        if self.fw.state == "Alarm":
            self._emit(UNLOCK_PROMPT, at)
        else:
            self._run_startup_lines(at)

    def _run_startup_lines(self, at: float) -> None:
        for line in self.startup_lines:
            if line:
                status = self._gcode(line, at, startup=True)
                self._emit(f">{line}:{status}", at)

    def _soft_reset(self, now: float) -> None:
        """Ctrl-X [G-RT]: ALARM:3 (6 when homing) if moving, the started line's ok, banner [G-MC mc_reset]."""
        fw = self.fw
        if now < fw.deaf_until:
            return
        if fw.critical and now < fw.reset_from:
            return  # "Disable any existing reset": it came during the alarm's 500 ms [G-PROT]
        alarm = 6 if fw.homing is not None else 3 if fw.seg is not None else 0
        if fw.homing is not None:
            self.lab.slide.homed = False
        self._stop_motion(now)
        out = now
        locked = fw.state in ("Alarm", "Sleep") or fw.critical or alarm > 0
        if alarm:
            self._emit(f"ALARM:{alarm}", now)
            out = now + ALARM_PAUSE_S
        self._reinitialise(out, stray_ok=fw.executing is not None, locked=locked)

    def _reinitialise(self, at: float, *, stray_ok: bool, locked: bool) -> None:
        """Back to main(): the started line's status, then everything re-initialised [G-MAIN]."""
        if stray_ok:
            self._emit("ok", at)
        fw = self.fw
        self.fw = _Firmware(t=fw.t, state="Alarm" if locked else "Idle", pos=fw.pos, planned=fw.pos,
                            deaf_until=at)
        if not self._dry:
            self._line.clear()  # serial_reset_read_buffer [G-MAIN]
        self._banner(at)

    # -- real-time bytes [G-PROT protocol_exec_rt_system] --------------------------------------
    def handle_realtime(self, char: bytes) -> None:
        now = self.lab.clock.now()
        fw = self.fw
        if char == b"\x18":
            self._soft_reset(now)
        elif fw.critical:
            return  # a limit alarm's loop serves nothing but reset [G-PROT]
        elif char == b"?":
            if fw.homing is not None:
                fw.status_deferred = True  # limits_go_home has no time for reports [G-LIM]
            else:
                self._emit(self._status(now), now)
        elif char == b"!":
            self._feed_hold(now)
        elif char == b"~":
            self._cycle_start(now)

    def _feed_hold(self, now: float) -> None:
        fw = self.fw
        if fw.state in ("Alarm", "Check", "Home", "Sleep", "Hold"):
            return
        fw.state = "Hold"
        if fw.seg is None:
            fw.hold_complete = True  # idle: nothing to stop [G-PROT]
            return
        fw.hold_complete = False
        self._decelerate(now)

    def _decelerate(self, now: float) -> None:
        """Replace the running segment by its stop at the acceleration limit (a hold coasts)."""
        fw = self.fw
        assert fw.seg is not None
        here, (_, speed) = fw.seg.point(now), fw.seg.at(now)
        stop = speed ** 2 / (2 * fw.seg.accel)
        fw.seg = _Segment(here, fw.seg.unit, stop, speed, speed, fw.seg.accel, now)
        fw.pos = here
        end = fw.seg.point(fw.seg.end)
        self._drive_slide(now, end[0], fw.seg.end - now)

    def _cycle_start(self, now: float) -> None:
        """``~`` resumes only a complete hold (Hold:0); during Hold:1 it is ignored [G-PROT]."""
        fw = self.fw
        if fw.state != "Hold" or not fw.hold_complete:
            return
        fw.hold_complete = False
        if fw.blocks:
            fw.state = "Run"
            self._start_block(now)
        else:
            fw.state = "Idle"
        self._drain(now)

    # -- status report [G-REP report_realtime_status] ----------------------------------------
    def _state_name(self) -> str:
        fw = self.fw
        if fw.state == "Hold":
            return "Hold:0" if fw.hold_complete else "Hold:1"
        return fw.state

    def _position(self, t: float) -> tuple[float, float, float]:
        fw = self.fw
        if fw.seg is not None:
            return fw.seg.point(t)
        if fw.homing is not None:
            return (self.lab.slide.position(t), fw.pos[1], fw.pos[2])
        return fw.pos

    def _status(self, now: float) -> str:
        fw = self.fw
        state = self._state_name()
        busy = state not in ("Idle", "Alarm")
        (x, y, z), (x0, y0, z0) = self._position(now), self.offset
        mpos = f"{_mm(x - x0)},{_mm(y - y0)},{_mm(z - z0)}"
        mask = int(self.settings[10])
        report = f"<{state}|{'MPos' if mask & 1 else 'WPos'}:{mpos}"
        if mask & 2:
            report += f"|Bf:{PLANNER_BLOCKS - len(fw.blocks)},{_RX_BUFFER}"
        speed = fw.seg.at(now)[1] * 60.0 if fw.seg is not None else self.settings[25] if fw.homing else 0.0
        report += f"|FS:{speed:.0f},0"
        if fw.wco_counter > 0:
            fw.wco_counter -= 1
        else:
            fw.wco_counter = _WCO_REFRESH[0 if busy else 1] - 1
            fw.ovr_counter = fw.ovr_counter or 1
            report += "|WCO:0.000,0.000,0.000"
        if fw.ovr_counter > 0:
            fw.ovr_counter -= 1
        else:
            fw.ovr_counter = _OVR_REFRESH[0 if busy else 1] - 1
            report += "|Ov:100,100,100"
        return report + ">"

    # -- the main loop: lines in order, when the firmware gets to them [G-PROT] ---------------
    def handle_line(self, line: str) -> None:
        if self.lab.clock.now() >= self.fw.deaf_until:  # a reset in progress flushes the buffer [G-MAIN]
            self.fw.pending.append(line)

    def _drain(self, t: float) -> None:
        """Execute waiting lines unless the main loop is held (hold, alarm loop, sleep, homing, dwell)."""
        fw = self.fw
        while fw.pending:
            if fw.critical or fw.homing is not None or fw.busy_until is not None or fw.soft_limit_stop:
                return
            if (fw.state == "Hold" and fw.hold_complete) or fw.state == "Sleep" or t < fw.deaf_until:
                return  # suspended once the hold is complete; during Hold:1 lines are still planned [G-PROT]
            fw.executing = None
            if not self._execute(fw.pending[0], t):
                fw.executing = fw.pending[0]  # blocked inside the line (mc_line, mc_dwell): its ok is due
                return
            fw.pending.pop(0)  # done, or still running it (homing, dwell, a soft limit) with executing set

    def _execute(self, raw: str, t: float) -> bool:
        """One line; False if it must wait (planner full, dwell needing an empty planner)."""
        text = _clean(raw)
        if text is None:
            self._emit("error:11", t)
        elif text == "":
            self._emit("ok", t)  # empty or comment line, for syncing [G-PROT]
        elif text.startswith("$"):
            return self._system(text, t)
        elif self.fw.state == "Alarm":
            self._emit("error:9", t)
        else:
            status = self._gcode(text, t)
            if status == "wait":
                return False
            if status:
                self._emit(status, t)
        return True

    # -- $ commands [G-SYS system_execute_line] -----------------------------------------------
    def _system(self, line: str, t: float) -> bool:
        fw = self.fw
        command = line[1:]
        if command == "":
            self._emit_lines(t, HELP, "ok")
        elif command[0] in "$GCX" and len(command) > 1 and not command.startswith("J"):
            self._emit("error:3", t)
        elif command == "$":
            if fw.state in ("Run", "Hold"):
                self._emit("error:8", t)  # "Takes too long to print" [G-SYS]
            else:
                self._emit_lines(t, *(self._format_setting(n) for n in self.settings), "ok")
        elif command == "G":
            self._emit_lines(t, self._modes(), "ok")
        elif command == "C":
            self._check_mode(t)
        elif command == "X":
            if fw.state == "Alarm":
                fw.state = "Idle"
                self._emit("[MSG:Caution: Unlocked]", t)
            self._emit("ok", t)
        elif command.startswith("J"):  # jogging is not emulated; a jog line is refused as unsupported
            self._emit("error:8" if fw.state != "Idle" else "error:3" if command[1:2] != "=" else "error:20", t)
        elif fw.state not in ("Idle", "Alarm"):
            self._emit("error:8", t)
        elif command == "#":
            self._emit_lines(t, *self._parameters(), "ok")
        elif command == "H":
            self._home(t)
        elif command.startswith("H"):
            self._emit("error:3", t)  # HOMING_SINGLE_AXIS_COMMANDS is off in the stock build
        elif command == "SLP":
            fw.state = "Sleep"
            self._halt_slide()
            self._emit_lines(t, "ok", "[MSG:Sleeping]")
        elif command.startswith("S"):
            self._emit("error:3", t)
        elif command == "I":
            self._emit_lines(t, *BUILD_INFO, "ok")
        elif command == "N":
            self._emit_lines(t, *(f"$N{n}={text}" for n, text in enumerate(self.startup_lines)), "ok")
        elif command in ("RST=$", "RST=#", "RST=*"):
            if command != "RST=#":  # the coordinate parameters ($RST=#) are all zero here already
                self.settings = dict(STOCK_SETTINGS)
                self.startup_lines = ["", ""]
            self._emit("[MSG:Restoring defaults]", t)
            self._reinitialise(t, stray_ok=True, locked=fw.state == "Alarm")  # mc_reset() [G-SYS]
        elif command.startswith("RST"):
            self._emit("error:3", t)
        else:
            self._emit(self._store(command, t), t)
        return True

    def _emit_lines(self, t: float, *lines: str) -> None:
        for text in lines:
            self._emit(text, t)

    def _check_mode(self, t: float) -> None:
        """``$C`` toggles check mode; leaving it resets (banner) [G-SYS]."""
        fw = self.fw
        if fw.state == "Check":
            self._emit("[MSG:Disabled]", t)
            self._reinitialise(t, stray_ok=True, locked=False)
        elif fw.state != "Idle":
            self._emit("error:8", t)
        else:
            fw.state = "Check"
            self._emit_lines(t, "[MSG:Enabled]", "ok")

    def _parameters(self) -> list[str]:
        """``$#``: the coordinate systems, G28/G30, G92, tool offset, probe [G-REP report_ngc_parameters]."""
        zero = "0.000,0.000,0.000"
        systems = [f"[G{n}:{zero}]" for n in range(54, 60)]
        return [*systems, f"[G28:{zero}]", f"[G30:{zero}]", f"[G92:{zero}]", "[TLO:0.000]", f"[PRB:{zero}:0]"]

    def _modes(self) -> str:
        fw = self.fw
        return (f"[GC:G{fw.motion} G54 G17 {'G20' if fw.inches else 'G21'} {'G90' if fw.absolute else 'G91'} "
                f"G94 M5 M9 T0 F{fw.feed / (25.4 if fw.inches else 1.0):.0f} S0]")

    def _format_setting(self, number: int) -> str:
        value = self.settings[number]
        return f"${number}={int(value)}" if number in _INTEGER_SETTINGS else f"${number}={value:.3f}"

    def _store(self, command: str, t: float) -> str:
        """``$x=val`` and ``$Nx=line`` [G-SYS]; a non-number after ``$`` is error:2 (read_float)."""
        startup = command.startswith("N")
        body = command[1:] if startup else command
        key = _NUMBER.match(body)
        if key is None or key.start() != 0:
            return "error:2"
        rest = body[key.end():]
        if not rest.startswith("="):
            return "error:3"
        if startup:
            if self.fw.state != "Idle":
                return "error:8"
            index, line = int(float(key.group())), rest[1:]
            status = self._gcode(line, t, startup=True)
            if status != "ok":
                return status
            if index >= len(self.startup_lines):
                return "error:3"
            self.startup_lines[index] = line
            return "ok"
        value_text = rest[1:]
        if not _NUMBER.fullmatch(value_text):
            return "error:2"
        number, value = int(float(key.group())), float(value_text)
        if number not in self.settings:
            return "error:3"
        if value < 0:
            return "error:4"
        if number == 0 and value < 3:
            return "error:6"
        if number == 20 and value and not self.settings[22]:
            return "error:10"
        self.settings[number] = int(value) if number in _INTEGER_SETTINGS else value
        if number == 22 and not value:
            self.settings[20] = 0  # homing off forces soft limits off [G-SYS settings.c]
        return "ok"

    # -- homing [G-SYS $H, G-MC mc_homing_cycle, G-LIM limits_go_home] ------------------------
    def _home(self, t: float) -> None:
        """Run the build's cycles in order; a cycle with an axis that has no switch ends in ALARM:9.

        Each X cycle: seek to the switch, pull off, locate slowly, pull off, with a debounce pause
        after each ($26) [G-LIM, N_HOMING_LOCATE_CYCLE 1]. The search covers 1.5x max travel.
        """
        fw = self.fw
        if not self.settings[22]:
            self._emit("error:5", t)
            return
        seek, locate, pulloff = self.settings[25], self.settings[24], self.settings[27]
        debounce = self.settings[26] / 1000.0
        position = list(fw.pos)  # X in the lab's motor frame: the switch is at 0
        end, fails = t, False
        for cycle in self.homing_cycles:
            travel = max(self.settings[130 + _AXES.index(axis)] for axis in cycle) * _SEARCH_SCALAR
            reachable = -travel <= position[0] <= 0.0
            if any(axis not in SWITCHED_AXES for axis in cycle) or ("X" in cycle and not reachable):
                for axis in cycle:  # the search runs to its end; X stops at its switch if it meets it
                    index = _AXES.index(axis)
                    position[index] = 0.0 if axis == "X" and reachable else position[index] + travel
                end += travel / seek * 60.0
                fails = True
                break
            end += (abs(position[0]) + 2 * pulloff) / seek * 60.0 + pulloff / locate * 60.0 + 4 * debounce
            position[0] = -pulloff
        fw.state = "Home"
        fw.homing = _Homing(end, fails, (position[0], position[1], position[2]))
        fw.executing = "$H"
        if position[0] != fw.pos[0]:
            self._drive_slide(t, position[0], end - t)
        if not fails and not self._dry:
            self.lab.slide.last_direction = -1  # the cycle ends pulling off the switch

    def _homing_done(self, t: float) -> None:
        fw = self.fw
        homing = fw.homing
        assert homing is not None
        fw.homing = None
        fw.pos = fw.planned = homing.final
        if homing.fails:
            fw.status_deferred = False
            fw.state = "Alarm"
            self._emit("ALARM:9", t)  # EXEC_ALARM_HOMING_FAIL_APPROACH, then mc_reset [G-LIM]
            self._reinitialise(t + ALARM_PAUSE_S, stray_ok=True, locked=True)
            return
        self.offset = (0.0, self.offset[1], self.offset[2])  # the switch is machine zero, minus pull-off
        if not self._dry:
            self.lab.slide.homed = True
        if fw.status_deferred:
            fw.status_deferred = False
            self._emit(self._status(t), t)  # the one pending '?', answered now [G-MC]
        fw.state = "Idle"
        fw.executing = None
        self._emit("ok", t)
        self._run_startup_lines(t)

    # -- G-code [G-GC gc_execute_line, the subset a slide uses] -------------------------------
    def _gcode(self, text: str, t: float, *, startup: bool = False) -> str:
        """Parse and execute; returns the status line, "" when already emitted, "wait" when blocked."""
        fw = self.fw
        words: dict[str, float] = {}
        groups: dict[str, float] = {}
        axis_command = False
        position = 0
        while position < len(text):
            letter = text[position]
            if not letter.isalpha():
                return "error:1"
            number = _NUMBER.match(text, position + 1)
            if number is None:
                return "error:2"
            value = float(number.group())
            position = number.end()
            if letter == "G":
                if not value.is_integer() or int(value) not in _G_GROUPS:
                    return "error:20"
                code = int(value)
                if code in (0, 1):
                    if axis_command:
                        return "error:24"  # two commands that both use axis words [G-GC]
                    axis_command = True
                group = _G_GROUPS[code]
                if group in groups:
                    return "error:21"
                groups[group] = code
            elif letter == "M":
                if not value.is_integer() or int(value) not in _M_GROUPS:
                    return "error:20"
                group = _M_GROUPS[int(value)]
                if group in groups:
                    return "error:21"
                groups[group] = value
            elif letter in _AXES or letter in _VALUE_WORDS:
                if letter in words:
                    return "error:25"
                if letter in _VALUE_WORDS and value < 0:
                    return "error:4"
                words[letter] = value
            else:
                return "error:20"  # A, B, C and other words the stock 3-axis build lacks
        scale = 25.4 if groups.get("units", 20 if fw.inches else 21) == 20 else 1.0
        non_modal = groups.get("non-modal")
        motion = int(groups.get("motion", fw.motion))
        axes = {letter: words[letter] * scale for letter in _AXES if letter in words}
        if non_modal == 4:
            if "P" not in words:
                return "error:28"
            if axes:
                return "error:31"
        elif "P" in words:
            return "error:36"
        if non_modal == 53 and motion not in (0, 1):
            return "error:30"
        feed = words["F"] * scale if "F" in words else fw.feed
        if axes and motion == 1 and feed <= 0:
            return "error:22"
        if non_modal == 4 and fw.blocks and not startup:
            return "wait"  # mc_dwell synchronises with the planner first [G-MC]
        target = self._target(axes, non_modal == 53, groups.get("distance"))
        if axes and self._violates_soft_limits(target) and fw.state != "Check":
            if not startup:
                self._soft_limit(t)
                return ""
            return "error:33"
        if axes and fw.state != "Check" and len(fw.blocks) >= PLANNER_BLOCKS and not startup:
            return "wait"  # mc_line waits for room in the planner [G-MC]
        fw.motion = motion
        fw.feed = feed
        fw.inches = scale != 1.0
        if "distance" in groups:
            fw.absolute = groups["distance"] == 90
        if non_modal == 4 and fw.state != "Check":
            fw.busy_until = t + words["P"]
            fw.executing = text
            return ""
        if axes and fw.state != "Check":
            self._plan(target, self._rate(motion, feed, target), t)
        return "ok"

    def _target(self, axes: dict[str, float], machine: bool, distance: float | None) -> tuple[float, float, float]:
        fw = self.fw
        absolute = machine or (distance == 90 if distance is not None else fw.absolute)
        result = []
        for index, letter in enumerate(_AXES):
            if letter not in axes:
                result.append(fw.planned[index])
            elif absolute:
                result.append(axes[letter] + self.offset[index])
            else:
                result.append(fw.planned[index] + axes[letter])
        return (result[0], result[1], result[2])

    def _violates_soft_limits(self, target: tuple[float, float, float]) -> bool:
        """system_check_travel_limits: machine space is [-max travel, 0] with $23=0 [G-SYS]."""
        if not self.settings[20]:
            return False
        return any(not -self.settings[130 + i] <= target[i] - self.offset[i] <= 0 for i in range(3))

    def _rate(self, motion: int, feed: float, target: tuple[float, float, float]) -> float:
        """Rapids at the axes' max rate, feeds at F, both capped per axis [planner.c limit_value_by_axis_maximum]."""
        limit = self._axis_limited(target, 110)
        return limit if motion == 0 else min(feed, limit)

    def _axis_limited(self, target: tuple[float, float, float], base: int) -> float:
        delta = [b - a for a, b in zip(self.fw.planned, target, strict=True)]
        length = math.sqrt(sum(d * d for d in delta))
        if length == 0:
            return self.settings[base]
        return min(self.settings[base + i] / abs(d / length) for i, d in enumerate(delta) if d)

    def _soft_limit(self, t: float) -> None:
        """limits_soft_check: stop under control if moving, then ALARM:2 and the reset lock [G-LIM]."""
        fw = self.fw
        if fw.seg is not None and fw.state == "Run":
            fw.state, fw.hold_complete, fw.soft_limit_stop = "Hold", False, True
            self._decelerate(t)
            fw.executing = "soft limit"
            return
        fw.executing = "soft limit"
        self._critical(t)

    def _critical(self, t: float) -> None:
        fw = self.fw
        self._stop_motion(t)
        fw.state, fw.critical, fw.reset_from = "Alarm", True, t + ALARM_PAUSE_S
        self._emit("ALARM:2", t)
        self._emit(RESET_PROMPT, t + ALARM_PAUSE_S)

    # -- the planner and the steppers -------------------------------------------------------
    def _plan(self, target: tuple[float, float, float], rate: float, t: float) -> None:
        fw = self.fw
        if target == fw.planned:
            return  # PLAN_EMPTY_BLOCK [G-MC]
        fw.blocks.append(_Block(target, rate))
        fw.planned = target
        if fw.state == "Idle" and fw.seg is None:
            fw.state = "Run"  # auto cycle start once the line is planned [G-PROT]
            self._start_block(t)

    def _start_block(self, t: float) -> None:
        fw = self.fw
        while fw.blocks:
            block = fw.blocks[0]
            delta = [b - a for a, b in zip(fw.pos, block.target, strict=True)]
            length = math.sqrt(sum(d * d for d in delta))
            if length < 1e-9:
                fw.blocks.pop(0)
                continue
            unit = (delta[0] / length, delta[1] / length, delta[2] / length)
            accel = min(self.settings[120 + i] / abs(u) for i, u in enumerate(unit) if u)
            fw.seg = _Segment(fw.pos, unit, length, 0.0, block.rate / 60.0, accel, t)
            self._drive_slide(t, block.target[0], fw.seg.end - t)
            return
        fw.seg = None
        fw.state = "Idle"

    def _segment_done(self, t: float) -> None:
        fw = self.fw
        assert fw.seg is not None
        fw.pos = fw.seg.point(fw.seg.end)
        fw.seg = None
        if fw.state == "Hold":
            fw.hold_complete = True
            if fw.soft_limit_stop:
                fw.soft_limit_stop = False
                fw.blocks.clear()
                self._critical(t)
            return
        if fw.blocks:
            fw.pos = fw.blocks.pop(0).target
        self._start_block(t)

    def _stop_motion(self, t: float) -> None:
        fw = self.fw
        fw.pos = self._position(t)
        fw.seg, fw.homing = None, None
        fw.blocks.clear()
        fw.planned = fw.pos
        self._halt_slide()

    # -- the lab's slide (X only) -------------------------------------------------------------
    def _drive_slide(self, t: float, target_mm: float, duration_s: float) -> None:
        """Move the lab's slide to ``target_mm`` over ``duration_s`` from time ``t`` (which may be past:
        events run when the emulator is next touched), through the lab's own start_move."""
        if self._dry:
            return
        slide = self.lab.slide
        start = slide.position(t)
        rate = abs(target_mm - start) / duration_s * 60.0 if duration_s > 0 else 0.0
        self.lab.start_move(target_mm, rate)
        slide.move_from_mm, slide.move_start_s = start, t
        slide.move_duration_s = duration_s if target_mm != start else 0.0

    def _halt_slide(self) -> None:
        if not self._dry:
            self.lab.halt_slide()


#: What a line loses outside comments: spaces, control characters and "/" (block delete) [G-PROT].
_DROPPED = str.maketrans("", "", "".join(map(chr, range(ord(" ") + 1))) + "/")


def _clean(line: str) -> str | None:
    """Spaces, control characters and comments dropped, upper case; None on overflow [G-PROT]."""
    if "(" not in line and ";" not in line:  # no comment (the usual line): one translate does the loop's work
        kept = line.translate(_DROPPED)
        return kept.upper() if len(kept) <= _LINE_LIMIT else None
    out: list[str] = []
    comment = ""
    for char in line:
        if comment == "(":
            if char == ")":
                comment = ""
            continue
        if comment == ";" or char <= " " or char == "/":
            continue
        if char in "(;":
            comment = char
            continue
        if len(out) >= _LINE_LIMIT:
            return None
        out.append(char.upper())
    return "".join(out)


def _mm(value: float) -> str:
    """Three decimals as GRBL prints positions, without a negative zero [G-REP].

    Formatting rounds the exact value half-even to three decimals, as round(value, 3) would first
    (at a third of round's cost); only a value that rounds to zero from below needs its sign dropped.
    """
    text = f"{value:.3f}"
    return "0.000" if text == "-0.000" else text
