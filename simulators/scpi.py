"""Base of the SCPI instrument emulators: header matching, the error queue, common commands.

What every SCPI instrument in the lab shares, written once so that an emulator is a
dispatch table plus its physics:
  - lines end in LF (CR/LF accepted); ``;`` separates commands in one line, and a
    header without a leading ``:`` continues the previous header's path
    (``MEAS:VOLT?;CURR?`` asks ``MEAS:CURR?``), the SCPI compound-command rule;
  - each node matches its short or long form, case-insensitively; optional nodes are
    written in brackets, e.g. ``[SOURce:]VOLTage[:LEVel]``;
  - a refused command leaves its error in a FIFO queue read with ``SYST:ERR?``
    (``+0,"No error"`` when empty) and has no effect; a refused *query* puts nothing
    in the output queue, so the host's read times out (IEEE 488.2 message exchange: a
    response exists only for a query that executed; over GPIB such a read is -420);
  - several queries in one line answer in one line, joined by ``;``;
  - ``*CLS`` clears the error queue [34970A-UG ch.5 SYST:ERR?], ``*RST`` does not
    (Agilent 33210A / 81160A guides, as collected in the project's research notes).
Replies wait until work in progress (``busy``) is done, so a scan costs simulated time.
"""

from __future__ import annotations

import re
from collections import deque
from typing import ClassVar

from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.lab import SimulatedLab

#: SCPI-1999 standard error codes and texts the emulators use.
ERROR_MESSAGES: dict[int, str] = {
    0: "No error",
    -102: "Syntax error",
    -104: "Data type error",
    -109: "Missing parameter",
    -113: "Undefined header",
    -221: "Settings conflict",
    -222: "Data out of range",
    -224: "Illegal parameter value",
    -350: "Queue overflow",
}


class SCPIError(Exception):
    """Raised by a command handler: the code goes to the error queue and the command has no effect."""

    def __init__(self, code: int) -> None:
        super().__init__(f'{code:+d},"{ERROR_MESSAGES[code]}"')
        self.code = code


def _node(mnemonic: str) -> str:
    """Regex for one node: its long form or its short form (the capitals, e.g. VOLTage -> VOLT)."""
    short = "".join(c for c in mnemonic if not c.islower())
    return f"(?:{re.escape(mnemonic.upper())}|{re.escape(short.upper())})"


def header_pattern(spec: str) -> re.Pattern[str]:
    """Compile a header spec such as ``[SOURce:]VOLTage[:LEVel]?`` into a case-insensitive regex."""
    parts: list[str] = []
    leading = True  # until the first mandatory node, optional nodes carry their colon after them
    for optional, text in re.findall(r"(\[?)([^\[\]]+)\]?", spec.rstrip("?")):
        body = ":".join(_node(node) for node in text.split(":") if node)
        if leading:
            parts.append(f"(?:{body}:)?" if optional else body)
            leading = bool(optional)
        else:
            parts.append(f"(?::{body})?" if optional else f":{body}")
    return re.compile(":?" + "".join(parts) + (r"\?" if spec.endswith("?") else ""), re.IGNORECASE)


class SCPIEmulator(LineEmulator):
    """A SCPI instrument: subclasses give ``identity`` and a ``commands`` table (header spec -> method name).

    A handler takes the parameter text (possibly empty) and returns the reply of a query,
    or None; it raises ``SCPIError`` to refuse. Handlers validate everything before they
    change state, so a refused command leaves the instrument as it was.
    """

    line_endings = b"\r\n"
    reply_termination = b"\n"
    #: ``*IDN?`` reply.
    identity: ClassVar[str] = ""
    #: ``*OPC?`` reply.
    opc_reply: ClassVar[str] = "1"
    #: Errors kept; beyond that the newest is replaced by -350 (Agilent L4400 UG "Error Conditions").
    error_queue_size: ClassVar[int] = 20
    #: The instrument's own commands: header spec -> name of the handler method.
    commands: ClassVar[dict[str, str]] = {}

    _COMMON: ClassVar[dict[str, str]] = {
        "*IDN?": "_identify",
        "*RST": "_reset_command",
        "*CLS": "_clear_status",
        "*OPC?": "_operation_complete",
        "*OPC": "_nothing",
        "*WAI": "_nothing",
        "SYSTem:ERRor[:NEXT]?": "_next_error",
    }

    def __init__(self, lab: SimulatedLab) -> None:
        super().__init__(lab)
        self.errors: deque[int] = deque()
        self.busy_until = lab.clock.now()
        self._table = [(header_pattern(spec), name) for spec, name in {**self._COMMON, **self.commands}.items()]
        self._handlers: dict[str, str] = {}

    def reset(self) -> None:
        """``*RST``: the instrument's factory state (subclasses)."""

    # -- parsing --------------------------------------------------------------------------------
    def handle_line(self, line: str) -> None:
        replies: list[str] = []
        path = ""
        for unit in line.split(";"):
            header, _, argument = unit.strip().partition(" ")
            if not header:
                continue
            if not header.startswith((":", "*")):
                header = path + header
            if not header.startswith("*"):
                path = header[: header.rfind(":") + 1].lstrip(":")
            answer = self.execute(header, argument.strip())
            if answer is not None:
                replies.append(answer)
        if replies:
            self.reply(";".join(replies), self.busy_until - self.lab.clock.now())

    def execute(self, header: str, argument: str) -> str | None:
        """Run one command; errors go to the queue and yield no reply."""
        name = self._handlers.get(header)
        if name is None:
            name = next((name for pattern, name in self._table if pattern.fullmatch(header)), None)
            if name is None:
                self.push_error(-113)
                return None
            self._handlers[header] = name  # a header as sent, resolved once
        try:
            return getattr(self, name)(argument)
        except SCPIError as error:
            self.push_error(error.code)
            return None

    def push_error(self, code: int) -> None:
        if len(self.errors) < self.error_queue_size:
            self.errors.append(code)
        else:
            self.errors[-1] = -350

    def busy(self, seconds: float) -> None:
        """Work that takes ``seconds``: replies from now on wait until it is done."""
        self.busy_until = max(self.busy_until, self.lab.clock.now()) + seconds

    # -- parameter helpers --------------------------------------------------------------------
    @staticmethod
    def parameters(argument: str) -> list[str]:
        """Split parameters at commas outside parentheses (channel lists contain commas)."""
        return [p.strip() for p in re.split(r",(?![^(]*\))", argument)] if argument else []

    @staticmethod
    def number(text: str, low: float, high: float) -> float:
        """A numeric parameter within [low, high]; MIN and MAX name the limits."""
        word = text.strip().upper()
        if not word:
            raise SCPIError(-109)
        if word in ("MIN", "MINIMUM", "MAX", "MAXIMUM"):
            return low if word.startswith("MIN") else high
        try:
            value = float(word)
        except ValueError:
            raise SCPIError(-104) from None
        if not low <= value <= high:
            raise SCPIError(-222)
        return value

    @staticmethod
    def boolean(text: str) -> bool:
        """ON|OFF|1|0."""
        word = text.strip().upper()
        if not word:
            raise SCPIError(-109)
        if word not in ("ON", "OFF", "1", "0"):
            raise SCPIError(-224)
        return word in ("ON", "1")

    # -- common commands ----------------------------------------------------------------------
    def _identify(self, _: str) -> str:
        return self.identity

    def _reset_command(self, _: str) -> None:
        self.reset()

    def _clear_status(self, _: str) -> None:
        self.errors.clear()

    def _operation_complete(self, _: str) -> str:
        return self.opc_reply

    def _nothing(self, _: str) -> None:
        return None

    def _next_error(self, _: str) -> str:
        code = self.errors.popleft() if self.errors else 0
        return f'{code:+d},"{ERROR_MESSAGES[code]}"'
