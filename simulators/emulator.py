"""Base of the protocol emulators: bytes in, command lines parsed, reply bytes out.

An emulator is the instrument's firmware as seen from its port. It is reached only
through transports (the ``ecdssim://`` pyserial scheme, which pyvisa-py also opens for ``ASRL`` resources),
never called by drivers directly. Replies can be scheduled for a later simulated
time (a measurement in progress), and the port hands them out when the host has
waited long enough on the shared clock.
"""

from __future__ import annotations

import heapq
import itertools
import re
from abc import ABC, abstractmethod

from ecds_lab.simulators.lab import SimulatedLab


class LineEmulator(ABC):
    """An instrument that reads terminated command lines and answers with terminated lines."""

    #: Short instrument name used in URLs (``ecdssim://LAB/<name>``) and fault injection.
    name: str = ""
    #: Bytes that end a command line coming from the host (any of them).
    line_endings: bytes = b"\n"
    #: Termination appended to every reply line.
    reply_termination: bytes = b"\n"
    #: Single bytes acted on immediately, outside the line buffer (GRBL's real-time commands).
    realtime_bytes: bytes = b""

    def __init__(self, lab: SimulatedLab) -> None:
        self.lab = lab
        self._line = bytearray()
        self._line_end = re.compile(b"[" + re.escape(self.line_endings) + b"]")
        #: One byte ends a line: a plain bytes split finds the lines (quicker than the pattern).
        self._single_ending = len(self.line_endings) == 1
        self._scheduled: list[tuple[float, int, bytes]] = []
        self._order = itertools.count()
        #: Set to a bytearray to capture every byte the host sends (protocol tests assert on it).
        self.wire: bytearray | None = None
        #: The command line being handled (what injected reply faults are keyed on).
        self._command = ""
        #: The host keeps the instrument's pauses between commands. A simulated station with pacing
        #: switched off sets this False, and an instrument that loses commands sent too fast (the
        #: HM8118) then takes them all.
        self.paced_host = True

    # -- the port side ------------------------------------------------------------------------
    def receive(self, data: bytes) -> None:
        """Bytes from the host: real-time bytes act at once, complete lines are handled in order."""
        if self.name in self.lab.faults.silent_instruments:
            return
        if self.wire is not None:
            self.wire += data
        if self.realtime_bytes:
            for byte in data:
                if byte in self.realtime_bytes:
                    self.handle_realtime(bytes((byte,)))
            data = data.translate(None, self.realtime_bytes)
        last = len(data) - 1
        if self._single_ending and not self._line and last >= 0 and data.find(self.line_endings) == last:
            # the usual write: one whole command line, nothing before it (what the general path below does)
            self._command = data[:-1].decode("ascii", errors="replace").strip()
            if self.lab.faults.stale_lines:  # injected faults only
                self._send_stale()
            self.handle_line(self._command)
            return
        self._line += data
        lines = self._line.split(self.line_endings) if self._single_ending else self._line_end.split(self._line)
        if len(lines) > 1:
            self._line = bytearray(lines.pop())  # the start of a line still to come
            for line in lines:
                self._command = line.decode("ascii", errors="replace").strip()
                if self.lab.faults.stale_lines:  # injected faults only
                    self._send_stale()
                self.handle_line(self._command)

    def next_reply_time(self) -> float | None:
        """Simulated time at which the earliest pending reply is ready, or None."""
        return self._scheduled[0][0] if self._scheduled else None

    def take_ready(self) -> bytes:
        """All reply bytes whose time has come."""
        scheduled = self._scheduled
        if not scheduled:  # nothing queued: no need to ask the clock
            return b""
        now = self.lab.clock.now()
        if scheduled[0][0] > now:
            return b""
        first = heapq.heappop(scheduled)[2]
        if not scheduled or scheduled[0][0] > now:  # the usual case: one reply line
            return first
        out = bytearray(first)
        while scheduled and scheduled[0][0] <= now:
            out += heapq.heappop(scheduled)[2]
        return bytes(out)

    def on_open(self) -> None:  # noqa: B027 - optional hook: most instruments take no notice of a port opening
        """The host opened the port (GRBL on an Arduino resets here)."""

    # -- the firmware side --------------------------------------------------------------------
    @abstractmethod
    def handle_line(self, line: str) -> None:
        """Act on one command line (without its termination)."""

    def handle_realtime(self, char: bytes) -> None:
        """Act on a real-time byte; an emulator that declares ``realtime_bytes`` must say what they do."""
        raise NotImplementedError(f"{self.name}: real-time byte {char!r} declared but not handled")

    def reply(self, text: str, delay_s: float = 0.0) -> None:
        """Queue one reply line, ready ``delay_s`` simulated seconds from now."""
        self.reply_at(text, self.lab.clock.now() + max(0.0, delay_s))

    def reply_at(self, text: str, ready: float) -> None:
        """Queue one reply line, ready at simulated time ``ready`` (now, if that has passed).

        Lines meant for one instant are given the same ``ready`` and leave in the order they were queued:
        the time is not re-derived from a clock read per line, which on a clock running with the wall
        clock (``ecds-lab simulate``) would differ between lines and could swap them.
        """
        now = self.lab.clock.now()
        if ready < now:
            ready = now
        faults = self.lab.faults
        if faults.unsolicited_lines or faults.short_replies:  # injected faults only: skipped on a clean link
            lines = [*self._unsolicited(), self._maybe_cut(text)]
        else:
            lines = [text]
        for line in lines:
            heapq.heappush(self._scheduled, (ready, next(self._order), line.encode("ascii") + self.reply_termination))

    def _unsolicited(self) -> list[str]:
        """An injected line sent unasked ahead of this reply (lab.faults.unsolicited_lines), if any."""
        queued = self.lab.faults.unsolicited_lines.get(self.name)
        return [queued.pop(0)] if queued else []

    def _send_stale(self) -> None:
        """An injected line sent unasked the moment this command arrives (lab.faults.stale_lines), if any: it is
        on the link, ahead of everything this command brings, when the host sends its next query."""
        queued = self.lab.faults.stale_lines.get(f"{self.name}:{self._command.upper()}")
        if queued:
            line = queued.pop(0)
            heapq.heappush(self._scheduled, (self.lab.clock.now(), next(self._order),
                                             line.encode("ascii") + self.reply_termination))

    def _maybe_cut(self, text: str) -> str:
        """The reply, or its first half when lab.faults.short_replies asks for it (a garbled link)."""
        key = f"{self.name}:{self._command.upper()}"
        left = self.lab.faults.short_replies.get(key)
        if left is None or left == 0:
            return text
        if left > 0:
            self.lab.faults.short_replies[key] = left - 1
        return text[:len(text) // 2]

    def drop_pending(self) -> None:
        """Forget queued replies (a reset empties the output buffer)."""
        self._scheduled.clear()
        self._line.clear()
