"""Reply formats: what a query's reply must look like before any of it becomes data.

A driver declares one :class:`ReplyFormat` beside each query (field count, number syntax, the
plausible range of each quantity). A reply cut short, garbled, or shifted by an unsolicited line
fails here with the reason, instead of being stored as a wrong number. :func:`ask_checked` asks,
checks, and on a bad reply drains what is waiting on the link and asks once more (a re-query,
for the queries whose protocol allows it) before giving up with an InstrumentError naming
instrument, command and reply.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from ecds_lab.drivers.instrument import Instrument
from ecds_lab.errors import ReplyFormatError, TransportTimeout

#: SCPI <NR1>/<NR2>/<NR3> numbers (IEEE 488.2 s. 8.7.2-8.7.4): sign, digits, optional point, exponent.
NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[Ee][+-]?\d+)?"
#: An exponent written with at least two digits (``E-05``, ``E+01``), as the instruments print NR3.
NR3 = r"[+-]?(?:\d+\.?\d*|\.\d+)[Ee][+-]\d{2,3}"
INTEGER = r"[+-]?\d+"
#: How long a drain waits for lines still on their way before re-asking (s).
DRAIN_S = 0.5


@dataclass(frozen=True)
class Field:
    """One comma-separated field: its name, syntax (a regular expression without capturing groups)
    and plausible range."""

    name: str
    syntax: str = NUMBER
    low: float = -float("inf")
    high: float = float("inf")
    #: ``syntax`` compiled once (a field is checked on every reply).
    pattern: re.Pattern[str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "pattern", re.compile(self.syntax))
        if self.pattern.groups:  # ReplyFormat reads the fields as its whole-reply pattern's groups
            raise ValueError(f"{self.name}: write the syntax's groups as (?:...), not capturing groups")

    def parse(self, text: str) -> float:
        text = text.strip()
        if not self.pattern.fullmatch(text):
            raise ValueError(f"{self.name} {text!r} is not a number of the expected form")
        value = float(text)
        if not self.low <= value <= self.high:
            raise ValueError(f"{self.name} {value:g} is outside the plausible {self.low:g}..{self.high:g}")
        return value


@dataclass(frozen=True)
class ReplyFormat:
    """A comma-separated reply: exactly these fields (or ``count`` repetitions of the first)."""

    fields: Sequence[Field]
    #: ``None``: exactly ``len(fields)``; a number: that many repetitions of ``fields[0]``.
    count: int | None = None
    #: Whether asking again is harmless (returns the same data, or a fresh reading of the same kind).
    requery: bool = True
    #: The whole reply as one pattern (each field a group, no spaces), per field count; compiled on first use.
    whole: dict[int | None, re.Pattern[str]] = field(default_factory=dict, init=False, repr=False, compare=False)

    def parse(self, reply: str, count: int | None = None) -> list[float]:
        """The reply's values; ValueError saying what is wrong with it."""
        expected = count if count is not None else self.count
        fields = self.fields if expected is None else (self.fields[0],) * expected
        # Fast path for the usual reply: every field well formed, no spaces, no extra comma (so the groups are
        # exactly the comma-separated parts); only the ranges are left to check. Anything else goes the field
        # by field way below, which accepts the same replies and says what is wrong with the others.
        whole = self.whole.get(expected)
        if whole is None:
            whole = self.whole[expected] = re.compile(",".join(f"({f.syntax})" for f in fields))
        match = whole.fullmatch(reply)
        if match is not None and reply.count(",") == len(fields) - 1:
            values = list(map(float, match.groups()))
            for f, value in zip(fields, values, strict=True):
                if not f.low <= value <= f.high:
                    break  # out of its range: the way below says which
            else:
                return values
        parts = reply.split(",")
        if len(parts) != len(fields):
            raise ValueError(f"{len(parts)} field(s), expected {len(fields)} "
                             f"({', '.join(f.name for f in fields)}): cut short or run together?")
        return [f.parse(part) for f, part in zip(fields, parts, strict=True)]


def drain(instrument: Instrument) -> list[str]:
    """Read and discard whatever lines are waiting on the link (an unsolicited line, a late reply)."""
    lines = []
    for _ in range(16):
        try:
            lines.append(instrument.transport.read_line(DRAIN_S))
        except TransportTimeout:
            break
    return lines


def ask_checked(instrument: Instrument, command: str, reply_format: ReplyFormat, *,
                timeout_s: float | None = None, count: int | None = None) -> tuple[str, list[float]]:
    """Ask, check the reply against its format; on a bad reply drain the link and ask once more
    (when the format allows a re-query). Raises ReplyFormatError naming instrument, command and reply."""
    reply = instrument.ask(command, timeout_s)
    try:
        return reply, reply_format.parse(reply, count)
    except ValueError as exc:
        first_problem = str(exc)
    if not reply_format.requery:
        raise ReplyFormatError(instrument.name, command, reply, first_problem)
    drain(instrument)
    second = instrument.ask(command, timeout_s)
    try:
        return second, reply_format.parse(second, count)
    except ValueError as exc:
        raise ReplyFormatError(instrument.name, command, second,
                               f"{exc}; the first reply {reply!r} was bad too ({first_problem})") from None
