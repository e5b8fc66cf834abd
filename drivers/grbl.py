"""GRBL 1.1 stepper controller driving the coil-target slide, as a ``Positioner``.

Sources (keys as in the project's protocol notes, Part B):
  [G-IF]   gnea/grbl doc/markdown/interface.md
  [G-IF2]  grbl/grbl doc/markdown/interface.md ("Streaming a G-Code Program to Grbl")
  [G-RT]   gnea/grbl doc/markdown/realtime_cmds.md
  [G-ERR]  gnea/grbl doc/csv/error_codes_en_US.csv
  [G-ALM]  gnea/grbl doc/csv/alarm_codes_en_US.csv
  [G-REP]  gnea/grbl grbl/report.c
  [G-PROT] gnea/grbl grbl/protocol.c
  [G-SYS]  gnea/grbl grbl/system.c
  [G-MAIN] gnea/grbl grbl/main.c (re-initialisation after reset)
  [G-CFG]  gnea/grbl grbl/config.h
  [G-LIM]  gnea/grbl grbl/limits.c, limits_go_home()
  [G-MC]   gnea/grbl grbl/motion_control.c (mc_line, mc_reset, mc_homing_cycle)
One line at a time: send it, wait for ``ok`` or ``error:N`` [G-IF2 "simple send-response"].
``ok`` means the move is queued, not done, so the end of a move is seen by polling the
real-time ``?`` until the state is ``Idle`` [G-IF2]. After homing, machine space is
negative (MPos = -$27) [G-LIM]; the coil-target distance is x = origin_mm + MPos.
Every decision here rests on replies only, so a recorded session replays identically.

What the firmware does that a naive driver trips over, and what this one does (docs/grbl.md):
- the banner comes up to ~2 s after the port opens (DTR resets the Arduino, the bootloader runs
  first): connect() waits for it (BANNER_WAIT_S) before it tries a Ctrl-X, and takes a late second
  banner or a stray ``ok`` in its stride;
- after ALARM:1/2 the firmware waits 500 ms and throws away any Ctrl-X that came meanwhile, then
  prints [MSG:Reset to continue] [G-PROT]: soft_reset() waits for that line before it resets;
- lines sent during a feed hold are not answered but queued and run after ``~`` [G-PROT]: commands
  are refused while the driver holds, and a line left without reply is flushed by a soft reset so
  it can never run later unseen;
- ``!`` decelerates first (Hold:1); ``~`` is ignored until the hold is complete (Hold:0) [G-PROT]:
  resume() waits for Hold:0;
- stock GRBL homes Z first [G-CFG HOMING_CYCLE_0]; on a slide with one switch (X) ``$H`` ends in
  ALARM:9 followed by a reset: home() reads the reset through and explains the build option once.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

from ecds_lab.drivers.instrument import Instrument
from ecds_lab.errors import InstrumentError, InvalidSettingError, TransportTimeout
from ecds_lab.transports.base import Transport

#: 115200 8N1 [G-IF]. Send "\n" only: GRBL ends a line at "\r" or "\n" and answers an empty
#: line with ``ok``, so CRLF yields two ``ok`` per command [G-PROT]. Replies end in "\r\n" [G-REP].
SERIAL_SETTINGS: dict[str, Any] = {
    "baudrate": 115200, "bytesize": 8, "parity": "N", "stopbits": 1,
    "write_termination": "\n", "read_termination": "\n", "timeout_s": 2.0, "min_interval_s": 0.0,
}
#: ``$H`` answers ``ok`` only after the cycle [G-SYS]; the search covers 1.5x max travel [G-IF].
HOMING_TIMEOUT_S = 120.0
#: The banner comes after the Arduino's DTR reset and its bootloader, up to ~2 s [G-IF]; wait longer.
BANNER_WAIT_S = 5.0
#: report_alarm_message() pauses 500 ms; a Ctrl-X during it is discarded [G-REP, G-PROT].
ALARM_PAUSE_S = 0.5
#: Printed once a limit alarm's lock-out is over and a reset will be taken [G-REP, G-PROT].
RESET_PROMPT = "[MSG:Reset to continue]"
#: What home() says when the cycle cannot find a switch (ALARM:9) [G-CFG].
HOMING_BUILD_NOTE = (
    "stock GRBL homes Z first (config.h HOMING_CYCLE_0 (1<<Z_AXIS)); firmware must be built with "
    "HOMING_CYCLE_0 (1<<X_AXIS) for a one-switch slide — config.h"
)
#: The start-up banner "Grbl 1.1h ['$' for help]"; the letter after 1.1 varies by build [G-REP].
BANNER_PREFIX = "Grbl 1.1"
#: Positions travel with 3 decimals in mm [G-REP]; closer than this is "already there".
_RESOLUTION_MM = 0.0005
#: The final position may differ from the target by at most this (one report digit plus rounding).
_ARRIVAL_TOLERANCE_MM = 0.002
#: Added to a predicted move time: the step segments end a little after the plan's ideal [G-MC].
_SETTLE_S = 0.01
#: Lines read while waiting for one reply before giving up (pushed messages are skipped).
_MAX_LINES = 64
#: Stock GRBL drives three axes (N_AXIS 3) [G-CFG]; A/B/C need another firmware.
_AXES = "XYZ"

#: error:N meanings [G-ERR, G-IF].
ERRORS: dict[int, str] = {
    1: "expected command letter", 2: "bad number format or missing value",
    3: "invalid statement ($ command not recognised)", 4: "negative value where a positive one is expected",
    5: "setting disabled: homing is not enabled ($22=0)", 6: "step pulse shorter than 3 us",
    7: "EEPROM read failed, defaults restored", 8: "not idle: this $ command needs the Idle state",
    9: "G-code lock: G-code is refused in Alarm or Jog state",
    10: "soft limits need homing enabled ($20=1 requires $22=1)", 11: "line overflow (too many characters)",
    12: "step rate above 30 kHz", 13: "safety door open", 14: "line length exceeded",
    15: "jog target beyond machine travel (jog ignored)", 16: "invalid jog command",
    17: "laser mode requires PWM output", 20: "unsupported or invalid G-code command",
    21: "modal group violation", 22: "undefined feed rate", 23: "command needs an integer value",
    24: "two G-code commands both need axis words", 25: "repeated G-code word",
    26: "no axis words where required", 27: "invalid line number", 28: "missing P or L value word",
    29: "G59.x work coordinate systems not supported", 30: "G53 only with G0/G1",
    31: "unused axis words", 32: "arc without in-plane axis words", 33: "invalid motion target",
    34: "arc radius error", 35: "arc missing in-plane offset word", 36: "unused value words",
    37: "G43.1 on the wrong axis", 38: "tool number above maximum",
}
#: ALARM:N meanings [G-ALM, G-IF].
ALARMS: dict[int, str] = {
    1: "hard limit triggered; position likely lost, re-home",
    2: "soft limit: G-code target exceeds machine travel; position retained, reset then unlock",
    3: "abort during cycle (reset while in motion); position likely lost, re-home",
    4: "probe fail: probe not in expected initial state",
    5: "probe fail: no contact within travel",
    6: "homing fail: reset during homing", 7: "homing fail: safety door opened during homing",
    8: "homing fail: pull-off did not clear the limit switch",
    9: "homing fail: limit switch not found within search distance",
}
#: Alarms that lock GRBL until a soft reset; it ignores ``?`` meanwhile [G-PROT, G-RT].
CRITICAL_ALARMS = (1, 2)
_HINTS = {
    5: "; enable homing with $22=1, or unlock() and work without a reference",
    9: "; home() or unlock() first",
}


@dataclass(frozen=True)
class Status:
    """One real-time status report ``<State|MPos:x,y,z|FS:f,s|...>`` [G-REP]."""

    raw: str
    state: str
    mpos_mm: tuple[float, ...]
    feed_mm_per_min: float | None
    fields: Mapping[str, str] = field(default_factory=dict)

    @property
    def base_state(self) -> str:
        """The state without its sub-state ("Hold:0" -> "Hold")."""
        return self.state.split(":", 1)[0]


def parse_status(line: str) -> Status:
    """Parse a status report; optional fields may come in any order, ``WPos`` is refused (needs $10=1)."""
    text = line.strip()
    if not (text.startswith("<") and text.endswith(">")):
        raise ValueError("a status report is enclosed in <...>")
    state, *parts = text[1:-1].split("|")
    fields: dict[str, str] = {}
    for part in parts:
        key, sep, value = part.partition(":")
        if not sep:
            raise ValueError(f"field {part!r} has no 'name:' prefix")
        fields[key] = value
    if "MPos" not in fields:
        if "WPos" in fields:
            raise ValueError("the report gives WPos (work position); set $10=1 so GRBL reports MPos")
        raise ValueError("the report has no MPos field")
    try:
        mpos = tuple(float(v) for v in fields["MPos"].split(","))
        rate = fields.get("FS", fields.get("F"))
        feed = float(rate.split(",")[0]) if rate is not None else None
    except ValueError:
        raise ValueError("a position or feed is not a number") from None
    if not state:
        raise ValueError("the report has no state")
    return Status(text, state, mpos, feed, fields)


def approach_waypoints(current_mm: float, target_mm: float, last_direction: int, approach: str,
                       overshoot_mm: float, travel_mm: tuple[float, float]) -> list[float]:
    """Distances (mm) a move from ``current_mm`` visits so its last move arrives from the side ``approach`` wants
    (positive, negative; direct: straight), clamped to the travel: at its end the slide cannot arrive from beyond.
    ``last_direction`` is the direction a move that needs no motion keeps. The planner predicts directions by it."""
    want = {"positive": 1, "negative": -1}.get(approach, 0)
    moving = abs(target_mm - current_mm) > _RESOLUTION_MM
    arriving = (1 if target_mm > current_mm else -1) if moving else last_direction
    if want == 0 or arriving == want:
        return [target_mm] if moving else []
    before = min(max(target_mm - want * overshoot_mm, travel_mm[0]), travel_mm[1])
    if abs(before - target_mm) <= _RESOLUTION_MM:  # at the end of travel: cannot arrive from that side
        return [target_mm] if moving else []
    return [before, target_mm]

class Grbl(Instrument):
    """A GRBL 1.1 controller moving one axis of the slide; positions in m at the interface, mm inside."""

    model = "GRBL"
    #: The slide's soft travel when the station gives none; config checks read it without building a driver.
    default_travel_mm: ClassVar[tuple[float, float]] = (15.0, 160.0)

    def __init__(
        self,
        transport: Transport,
        *,
        origin_mm: float = 160.0,
        min_mm: float = default_travel_mm[0],
        max_mm: float = default_travel_mm[1],
        feed_mm_per_min: float = 600.0,
        approach: Literal["positive", "negative", "direct"] = "positive",
        overshoot_mm: float = 0.5,
        poll_interval_s: float = 0.05,
        axis: str = "X",
        acceleration_mm_per_s2: float = 10.0,
    ) -> None:
        super().__init__(transport)
        if not min_mm < max_mm:
            raise InvalidSettingError(f"{self.name}: min_mm {min_mm:g} must be below max_mm {max_mm:g}")
        if approach not in ("positive", "negative", "direct"):
            raise InvalidSettingError(f"{self.name}: approach {approach!r} is not one of positive, negative, direct")
        if not isinstance(axis, str) or len(axis) != 1 or axis.upper() not in _AXES:
            raise InvalidSettingError(
                f"{self.name}: axis {axis!r} is not one of {', '.join(_AXES)}; stock GRBL 1.1 has three axes "
                "(A/B/C need a firmware built for more)"
            )
        for label, value in (("overshoot_mm", overshoot_mm), ("poll_interval_s", poll_interval_s)):
            if not value >= 0:
                raise InvalidSettingError(f"{self.name}: {label} must be >= 0, got {value!r}")
        if not acceleration_mm_per_s2 > 0:
            raise InvalidSettingError(f"{self.name}: acceleration_mm_per_s2 must be > 0 (GRBL's $120), "
                                      f"got {acceleration_mm_per_s2!r}")
        self.origin_mm = float(origin_mm)
        self.min_mm, self.max_mm = float(min_mm), float(max_mm)
        self.min_position_m, self.max_position_m = self.min_mm * 1e-3, self.max_mm * 1e-3
        self.feed_mm_per_min = self._check_feed(feed_mm_per_min)
        self.approach = approach
        self.overshoot_mm = float(overshoot_mm)
        self.poll_interval_s = float(poll_interval_s)
        #: The axis' $120..$122 (stock 10 mm/s^2): only used to predict how long a move takes.
        self.acceleration_mm_per_s2 = float(acceleration_mm_per_s2)
        self.axis = axis.upper()
        self._axis_index = _AXES.index(self.axis)
        self.banner = ""
        self._connected = False
        self._critical_alarm = False
        self._reset_prompt_seen = False
        self._held = False
        self._direction = 0

    # -- start-up ------------------------------------------------------------------------
    def wake_up(self, alarms: list[str] | None = None, timeout_s: float | None = None) -> str:
        """Read up to the start-up banner and return it [G-REP report_init_message].

        A stray ``ok`` before it (the status of the line a reset interrupted [G-PROT, G-MC]) is skipped.
        """
        errors: list[str] = []
        self.banner = self._read_until("(start-up)", lambda line: line.startswith("Grbl "), alarms=alarms,
                                       errors=errors, timeout_s=timeout_s)
        self._critical_alarm = self._reset_prompt_seen = self._held = False
        if "error:7" in errors:  # settings_init() failed and wrote the defaults [G-PROT, settings.c]
            raise self.fail("(start-up)", "error:7", ERRORS[7] + "; GRBL now runs on its stock $ settings "
                                                    "(homing, soft limits, travel): restore the slide's before moving")
        return self.banner

    def connect(self) -> str:
        """Wait for the banner GRBL prints when the port opens (DTR reset, then the bootloader, up to
        ~2 s), soft-resetting for one only if none comes within BANNER_WAIT_S (a port without DTR reset)."""
        try:
            banner = self.wake_up(timeout_s=BANNER_WAIT_S)
        except TransportTimeout:
            self.transport.write_bytes(b"\x18")
            banner = self.wake_up(timeout_s=BANNER_WAIT_S)
        if not banner.startswith(BANNER_PREFIX):
            raise self.fail("(start-up)", banner, f"this driver speaks {BANNER_PREFIX}")
        self._connected = True
        # also consumes "[MSG:'$H'|'$X' to unlock]" when GRBL starts locked [G-PROT]; a second, late
        # banner (the boot's, when a Ctrl-X raced it) is taken as the current one
        self.status(banner_ok=True)
        return self.banner

    def _ensure_connected(self) -> None:
        if not self._connected:
            self.connect()

    # -- commands with ok / error:N ------------------------------------------------------
    def identity(self) -> str:
        """``$I`` build info: "Grbl <version.build> [OPT:...]" [G-REP report_build_info]."""
        self._ensure_connected()
        self._check_not_held("$I")
        lines: list[str] = []
        self._command("$I", collect=lines)
        info = {key: value for key, _, value in (line.strip("[]").partition(":") for line in lines)}
        version = info.get("VER", "?").split(":", 1)[0]
        return f"Grbl {version}" + (f" [OPT:{info['OPT']}]" if "OPT" in info else "")

    def unlock(self) -> None:
        """``$X``: leave the Alarm lock without homing; GRBL answers [MSG:Caution: Unlocked] then ok [G-SYS]."""
        self._ensure_connected()
        self._check_not_held("$X")
        self._command("$X")

    def home(self) -> None:
        """``$H``: run the homing cycle; ``ok`` comes when it is over [G-SYS], MPos is then -$27 [G-LIM].

        A failed cycle prints ALARM:N, and after GRBL's own reset (mc_reset [G-MC]) the ``ok`` of
        ``$H``, the banner and the unlock prompt: all read here, then one error that says why.
        """
        self._ensure_connected()
        self._check_not_held("$H")
        self.transport.write("$H")
        reply = self._read_until("$H", lambda line: line == "ok" or line.startswith("ALARM:"),
                                 timeout_s=HOMING_TIMEOUT_S)
        if reply.startswith("ALARM:"):
            self.wake_up(timeout_s=BANNER_WAIT_S)  # skips the stray "ok" of $H that precedes the banner
            raise self._homing_alarm(reply)
        self._direction = 0  # the pull-off direction depends on $23; the next approach re-establishes it

    # -- real-time commands [G-RT] --------------------------------------------------------
    def status(self, *, banner_ok: bool = False) -> Status:
        """One ``?`` status report (refused locally while a limit alarm makes GRBL ignore ``?`` [G-RT])."""
        self._ensure_connected()
        if self._critical_alarm:
            raise self.fail("?", "", "GRBL is halted by a limit alarm and ignores '?'; soft_reset() or stop() first")
        self.transport.write_bytes(b"?")
        line = self._read_until("?", lambda text: text.startswith("<"), banner_ok=banner_ok)
        try:
            status = parse_status(line)
        except ValueError as exc:
            raise self.fail("?", line, str(exc)) from None
        if status.base_state != "Run":
            self._held = status.base_state == "Hold"
        return status

    def feed_hold(self) -> None:
        """``!``: decelerate (Hold:1) to a stop and hold (Hold:0); no reply [G-RT]. Until resume() or a
        reset, GRBL would only queue lines, so the driver refuses to send any."""
        self.transport.write_bytes(b"!")
        self._held = True

    def resume(self) -> None:
        """``~`` once the hold is complete: GRBL ignores it during the deceleration (Hold:1) [G-PROT]."""
        self._ensure_connected()
        for _ in range(_MAX_LINES):
            status = self.status()
            # a '?' sent right after '!' can still report Run: the report is served before the hold [G-PROT]
            if status.state != "Hold:1" and not (status.base_state in ("Run", "Jog") and self._held):
                break
            self._held = True
            self.transport.clock.sleep(self.poll_interval_s)
        else:
            raise self.fail("~", status.raw, "the feed hold did not complete (still Hold:1)")
        self.transport.write_bytes(b"~")
        self._held = False

    def soft_reset(self) -> str:
        """Ctrl-X: halt and re-initialise; GRBL prints its banner again [G-RT, G-REP].

        Position is kept unless it was moving, which raises ALARM:3 [G-ALM]; that alarm is
        reported as InstrumentError after the banner has been read, so the link stays in step.
        After a limit alarm the reset is sent only once GRBL says [MSG:Reset to continue]: one sent
        during the alarm's 500 ms pause would be discarded [G-PROT].
        """
        self._ensure_connected()
        if self._critical_alarm and not self._reset_prompt_seen:
            self._await_reset_prompt()
        self.transport.write_bytes(b"\x18")
        alarms: list[str] = []
        banner = self.wake_up(alarms=alarms)
        self._connected = True
        self.status()
        if alarms:
            raise self._alarm("\x18", alarms[0])
        return banner

    def stop(self) -> None:
        """Feed hold, wait until the hold is complete, then soft reset: stops without losing position."""
        self._ensure_connected()
        self.feed_hold()
        if not self._critical_alarm:
            for _ in range(_MAX_LINES):
                if self.status().state not in ("Run", "Jog", "Hold:1"):
                    break
                self.transport.clock.sleep(self.poll_interval_s)
        self.soft_reset()

    # -- Positioner ----------------------------------------------------------------------
    def position_m(self) -> float:
        """Coil-target distance from one status report."""
        return self._x_mm(self.status()) * 1e-3

    def move_to(self, position_m: float, speed_m_per_s: float | None = None) -> int:
        """Move to a distance, wait until Idle there; returns the direction of the final approach.

        With approach "positive" the last move always runs in +x (from target - overshoot when
        the target is below), "negative" the mirror, "direct" straight; this takes up backlash.
        Returns the current direction when no motion was needed (0 if none is known yet).
        """
        target = self._check_target(position_m)
        feed = self.feed_mm_per_min if speed_m_per_s is None else self._check_feed(speed_m_per_s, scale=60e3)
        status = self.status()
        if status.base_state == "Hold":
            raise self.fail("?", status.raw, "GRBL is in a feed hold; a move sent now would only be queued "
                                             "until '~': resume() or stop() first")
        current = self._mpos(status)
        for waypoint in self._waypoints(current + self.origin_mm, target):
            end = float(f"{waypoint - self.origin_mm:.3f}")
            self._move(current, end, feed)
            self._direction = 1 if end > current else -1
            current = end
        return self._direction

    # -- internals -----------------------------------------------------------------------
    def _check_target(self, position_m: float) -> float:
        try:
            x_mm = round(float(position_m) * 1e3, 6)
        except (TypeError, ValueError):
            raise InvalidSettingError(f"{self.name}.move_to: {position_m!r} is not a number") from None
        if not self.min_mm <= x_mm <= self.max_mm:
            raise InvalidSettingError(
                f"{self.name}.move_to: {x_mm:g} mm is outside the allowed {self.min_mm:g}..{self.max_mm:g} mm"
            )
        return x_mm

    def _check_feed(self, value: float, scale: float = 1.0) -> float:
        """A feed in mm/min (``value`` times ``scale``), at least 1, rounded as the F word carries it."""
        try:
            feed = float(value) * scale
        except (TypeError, ValueError):
            feed = math.nan
        if not (math.isfinite(feed) and feed >= 1.0):
            raise InvalidSettingError(f"{self.name}: feed {value!r} gives {feed:g} mm/min; at least 1 mm/min is needed")
        return float(f"{feed:.0f}")

    def _waypoints(self, current: float, target: float) -> list[float]:
        """Distances to visit so the last move arrives from the wanted side (clamped to the travel)."""
        return approach_waypoints(current, target, self._direction, self.approach, self.overshoot_mm,
                                  (self.min_mm, self.max_mm))

    def _move(self, start: float, end: float, feed: float) -> None:
        """One ``G90 G1`` move, then wait: sleep the expected time, poll ``?`` until Idle."""
        command = f"G90 G1 {self.axis}{end + 0.0:.3f} F{feed:.0f}"
        self._command(command)
        expected = self._move_time_s(abs(end - start), feed) + _SETTLE_S
        budget = 2 * expected + 10.0
        waited = expected
        self.transport.clock.sleep(expected)
        while True:
            status = self.status()
            if status.base_state == "Idle":
                break
            if status.base_state not in ("Run", "Jog"):
                hint = "; resume() or stop()" if status.base_state in ("Hold", "Door") else ""
                raise self.fail(command, status.raw, f"motion stopped in state {status.state}{hint}")
            if waited > budget:
                raise self.fail(command, status.raw, f"still moving after {waited:.1f} s, expected {expected:.1f} s")
            rate = max(status.feed_mm_per_min or 0.0, 1.0)
            pause = max(self.poll_interval_s, self._move_time_s(abs(end - self._mpos(status)), feed, rate))
            self.transport.clock.sleep(pause)
            waited += pause
        reached = self._mpos(status)
        if abs(reached - end) > _ARRIVAL_TOLERANCE_MM:
            raise self.fail(command, status.raw, f"stopped at MPos {reached:.3f} mm instead of {end:.3f} mm")

    def _move_time_s(self, distance_mm: float, feed: float, now_mm_per_min: float = 0.0) -> float:
        """Time of a move of ``distance_mm`` ending at rest, from ``now_mm_per_min`` up to ``feed``, at the
        axis' acceleration (GRBL plans trapezoids [planner.c]); a lower bound for polling."""
        a, v, v0 = self.acceleration_mm_per_s2, feed / 60.0, min(now_mm_per_min, feed) / 60.0
        if distance_mm <= 0:
            return 0.0
        up, down = (v * v - v0 * v0) / (2 * a), v * v / (2 * a)
        if up + down <= distance_mm:
            return (v - v0) / a + (distance_mm - up - down) / v + v / a
        peak = math.sqrt((2 * a * distance_mm + v0 * v0) / 2)
        if peak <= v0:  # already braking
            return 2 * distance_mm / v0
        return (peak - v0) / a + peak / a

    def _check_not_held(self, command: str) -> None:
        """GRBL queues lines during a feed hold and answers them only after ``~`` [G-PROT]."""
        if self._held:
            raise self.fail(command, "", "GRBL is in a feed hold and would only queue this line until '~'; "
                                         "resume() or stop() first")

    def _await_reset_prompt(self) -> None:
        """Read until [MSG:Reset to continue] (GRBL prints it 500 ms after a limit alarm) [G-PROT]."""
        try:
            self._read_until("\x18", lambda line: line == RESET_PROMPT, timeout_s=ALARM_PAUSE_S + 1.5)
        except TransportTimeout:
            self.transport.clock.sleep(ALARM_PAUSE_S)  # prompt lost: the lock-out is over by now anyway
        self._reset_prompt_seen = True

    def _homing_alarm(self, line: str) -> InstrumentError:
        code = _code(line)
        meaning = ALARMS.get(code, "unknown alarm") if code is not None else "malformed alarm"
        if code == 9:
            meaning += "; " + HOMING_BUILD_NOTE
        return self.fail("$H", line, meaning + "; GRBL reset itself and is locked (Alarm)")

    def _mpos(self, status: Status) -> float:
        if len(status.mpos_mm) <= self._axis_index:
            raise self.fail("?", status.raw, f"no {self.axis} coordinate in MPos")
        return status.mpos_mm[self._axis_index]

    def _x_mm(self, status: Status) -> float:
        return self.origin_mm + self._mpos(status)

    def _command(self, command: str, *, collect: list[str] | None = None, timeout_s: float | None = None) -> None:
        """Send one line and wait for its ``ok``; ``error:N`` and ``ALARM:N`` raise with their meaning.

        A line left without reply may still sit in GRBL's buffer (a hold queues lines [G-PROT]) and
        answer or move later: it is flushed with a soft reset, so the link stays in step."""
        self.transport.write(command)
        try:
            self._read_until(command, lambda line: line == "ok", collect=collect, timeout_s=timeout_s)
        except TransportTimeout:
            self._flush_after_timeout(command)

    def _flush_after_timeout(self, command: str) -> None:
        waited = self.transport.timeout_s
        if self._critical_alarm and not self._reset_prompt_seen:
            self._await_reset_prompt()
        self.transport.write_bytes(b"\x18")
        try:
            self.wake_up(alarms=[], timeout_s=BANNER_WAIT_S)
        except TransportTimeout:
            raise self.fail(command, "", f"no reply within {waited:g} s, and none to a soft reset either: "
                                         "is the controller powered and on this port?") from None
        raise self.fail(command, "", f"no reply within {waited:g} s; GRBL may have queued the line (a feed "
                                     "hold queues lines until '~'), so it was flushed with a soft reset and "
                                     "will not run; position kept unless GRBL reported ALARM:3")

    def _read_until(
        self,
        command: str,
        wanted: Callable[[str], bool],
        *,
        collect: list[str] | None = None,
        alarms: list[str] | None = None,
        errors: list[str] | None = None,
        timeout_s: float | None = None,
        banner_ok: bool = False,
    ) -> str:
        """Read lines until ``wanted`` (each within ``timeout_s``, default the link's); skip pushed messages
        ([MSG:...], empty lines, stray reports)."""
        line = ""
        for _ in range(_MAX_LINES):
            line = self.transport.read_line(timeout_s).strip()
            if wanted(line):
                return line
            if line.startswith("ALARM:"):
                if alarms is None:
                    raise self._alarm(command, line)
                alarms.append(line)
            elif line.startswith("error:"):
                if errors is None:
                    raise self._error(command, line)
                errors.append(line)
            elif line.startswith("Grbl "):
                self.banner, self._critical_alarm, self._held = line, False, False
                if not banner_ok:
                    raise self.fail(command, line, "the controller reset; position and modal state may be lost")
            elif line == RESET_PROMPT:
                self._reset_prompt_seen = True
            elif collect is not None and line.startswith("[") and not line.startswith("[MSG:"):
                collect.append(line)
        raise self.fail(command, line, f"no reply among {_MAX_LINES} lines")

    def _error(self, command: str, line: str) -> InstrumentError:
        code = _code(line)
        meaning = ERRORS.get(code, "unknown error") if code is not None else "malformed error"
        return self.fail(command, line, meaning + _HINTS.get(code or 0, ""))

    def _alarm(self, command: str, line: str) -> InstrumentError:
        code = _code(line)
        if code in CRITICAL_ALARMS:
            self._critical_alarm = True
        meaning = ALARMS.get(code, "unknown alarm") if code is not None else "malformed alarm"
        return self.fail(command, line, meaning)


def _code(line: str) -> int | None:
    """N of ``error:N`` / ``ALARM:N``."""
    try:
        return int(line.split(":", 1)[1])
    except (IndexError, ValueError):
        return None
