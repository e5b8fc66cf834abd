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

The IEEE 488.2 mandatory common commands and status model [IEEE 488.2 ch. 10-11; 34970A-UG ch.5
"The SCPI Status System"; HMP SCPI manual "Status reporting"]:
  - the Standard Event Status Register (``*ESR?`` reads and clears it): bit 0 OPC (set by ``*OPC``
    once pending work is done), 2 query error (-400s), 3 device-dependent error (-300s), 4 execution
    error (-200s), 5 command error (-100s), 7 power on; ``*ESE``/``*ESE?`` its enable mask;
  - the Status Byte (``*STB?``, not cleared by reading): bit 2 error/event queue not empty, bit 4
    MAV (a reply waits in the output queue), bit 5 ESB (an enabled ESR bit is set), bit 6 MSS
    (an enabled status-byte bit is set); ``*SRE``/``*SRE?`` its enable mask (bit 6 ignored);
  - ``*CLS`` clears the error queue and the ESR, not the enable masks; ``*TST?`` answers 0 (passed);
    ``*OPC?`` answers once pending work is done; ``*WAI`` holds later replies until then, as every
    reply here does anyway; a common command given a parameter it does not take is -108.
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
    -108: "Parameter not allowed",
    -109: "Missing parameter",
    -113: "Undefined header",
    -221: "Settings conflict",
    -222: "Data out of range",
    -224: "Illegal parameter value",
    -230: "Data corrupt or stale",
    -350: "Queue overflow",
}


#: Standard Event Status Register bits [IEEE 488.2 11.5.1].
ESR_OPERATION_COMPLETE = 1 << 0
ESR_QUERY_ERROR = 1 << 2
ESR_DEVICE_ERROR = 1 << 3
ESR_EXECUTION_ERROR = 1 << 4
ESR_COMMAND_ERROR = 1 << 5
ESR_POWER_ON = 1 << 7
#: Which ESR bit an error class sets: -100s command, -200s execution, -300s device, -400s query [SCPI-1999 21.8].
_ERROR_CLASS_BITS = {-100: ESR_COMMAND_ERROR, -200: ESR_EXECUTION_ERROR, -300: ESR_DEVICE_ERROR,
                     -400: ESR_QUERY_ERROR}
#: Status Byte bits [IEEE 488.2 11.2; SCPI-1999 9.1: bit 2 error/event queue].
STB_ERROR_QUEUE = 1 << 2
STB_MESSAGE_AVAILABLE = 1 << 4
STB_EVENT_SUMMARY = 1 << 5
STB_MASTER_SUMMARY = 1 << 6


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
    #: Registers read back with a sign (``+32``), as the Keysight units print NR1; the HMP prints ``32``.
    signed_registers: ClassVar[bool] = False
    #: Duration of ``*TST?`` (an assumption; the manuals give none).
    self_test_s: ClassVar[float] = 1.0

    _COMMON: ClassVar[dict[str, str]] = {
        "*IDN?": "_identify",
        "*RST": "_reset_command",
        "*CLS": "_clear_status",
        "*OPC?": "_operation_complete",
        "*OPC": "_set_operation_complete",
        "*WAI": "_wait",
        "*ESR?": "_event_status",
        "*ESE": "_set_event_enable",
        "*ESE?": "_event_enable",
        "*STB?": "_status_byte",
        "*SRE": "_set_service_request_enable",
        "*SRE?": "_service_request_enable",
        "*TST?": "_self_test",
        "SYSTem:ERRor[:NEXT]?": "_next_error",
    }

    def __init__(self, lab: SimulatedLab) -> None:
        super().__init__(lab)
        self.errors: deque[int] = deque()
        self.busy_until = lab.clock.now()
        #: Standard Event Status Register and its enable mask; the status byte's enable mask.
        self.event_status = ESR_POWER_ON
        self.event_enable = 0
        self.service_request_enable = 0
        self._opc_pending_at: float | None = None
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
            self.reply_at(";".join(replies), self.busy_until)

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
        """Queue an error and set its class's bit in the Standard Event Status Register."""
        if len(self.errors) < self.error_queue_size:
            self.errors.append(code)
        else:
            self.errors[-1] = -350
        self.event_status |= _ERROR_CLASS_BITS.get(-((-code) // 100) * 100, ESR_DEVICE_ERROR)

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
    def integer(text: str, low: int, high: int) -> int:
        """A whole-number parameter within [low, high] (NR1; a decimal value is rounded, as IEEE 488.2 allows)."""
        return round(SCPIEmulator.number(text, low, high))

    @staticmethod
    def no_parameter(argument: str) -> None:
        """Refuse a parameter given to a command that takes none (-108)."""
        if argument:
            raise SCPIError(-108)

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
    def _identify(self, argument: str) -> str:
        self.no_parameter(argument)
        return self.identity

    def _reset_command(self, argument: str) -> None:
        self.no_parameter(argument)
        self.reset()

    def _clear_status(self, argument: str) -> None:
        self.no_parameter(argument)
        self.errors.clear()
        self.event_status = 0
        self._opc_pending_at = None

    def _operation_complete(self, argument: str) -> str:
        self.no_parameter(argument)
        return self.opc_reply

    def _set_operation_complete(self, argument: str) -> None:
        """``*OPC``: the OPC bit is set once the work now in progress is done."""
        self.no_parameter(argument)
        self._opc_pending_at = self.busy_until

    def _wait(self, argument: str) -> None:
        """``*WAI``: later commands wait for pending work; every reply here already waits for ``busy``."""
        self.no_parameter(argument)

    def _nothing(self, _: str) -> None:
        return None

    def _settle_opc(self) -> None:
        if self._opc_pending_at is not None and self.lab.clock.now() >= self._opc_pending_at:
            self.event_status |= ESR_OPERATION_COMPLETE
            self._opc_pending_at = None

    def _event_status(self, argument: str) -> str:
        """``*ESR?``: the register, cleared by reading it."""
        self.no_parameter(argument)
        self._settle_opc()
        value, self.event_status = self.event_status, 0
        return f"{value:+d}" if self.signed_registers else str(value)

    def _set_event_enable(self, argument: str) -> None:
        self.event_enable = self.integer(argument, 0, 255)

    def _event_enable(self, argument: str) -> str:
        self.no_parameter(argument)
        return f"{self.event_enable:+d}" if self.signed_registers else str(self.event_enable)

    def status_byte(self) -> int:
        """The status byte as ``*STB?`` reports it (a serial poll would put RQS in bit 6 instead)."""
        self._settle_opc()
        byte = STB_ERROR_QUEUE if self.errors else 0
        if self.next_reply_time() is not None:
            byte |= STB_MESSAGE_AVAILABLE
        if self.event_status & self.event_enable:
            byte |= STB_EVENT_SUMMARY
        if byte & self.service_request_enable & ~STB_MASTER_SUMMARY:
            byte |= STB_MASTER_SUMMARY
        return byte

    def _status_byte(self, argument: str) -> str:
        self.no_parameter(argument)
        value = self.status_byte()
        return f"{value:+d}" if self.signed_registers else str(value)

    def _set_service_request_enable(self, argument: str) -> None:
        self.service_request_enable = self.integer(argument, 0, 255) & ~STB_MASTER_SUMMARY

    def _service_request_enable(self, argument: str) -> str:
        self.no_parameter(argument)
        value = self.service_request_enable
        return f"{value:+d}" if self.signed_registers else str(value)

    def _self_test(self, argument: str) -> str:
        """``*TST?``: 0 is a passed self-test [IEEE 488.2 10.38]; the test takes ``self_test_s``."""
        self.no_parameter(argument)
        self.busy(self.self_test_s)
        return "+0" if self.signed_registers else "0"

    def _next_error(self, argument: str) -> str:
        self.no_parameter(argument)
        code = self.errors.popleft() if self.errors else 0
        return f'{code:+d},"{ERROR_MESSAGES[code]}"'
