"""Declarative driver base: one ``Control`` per instrument command, validation beside it.

Modelled on PyMeasure's ``Instrument.control``: a driver class reads like its
manual's command table. Values are validated *before* anything is sent, so bad
input never reaches the instrument.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any, Generic, TypeVar

from ecds_lab.errors import InstrumentError, InvalidSettingError
from ecds_lab.transports.base import Transport

T = TypeVar("T")
Validator = Callable[[Any, str], Any]


# -- validators: each returns the value to send, or raises InvalidSettingError ---------------
def in_range(low: float, high: float, unit: str = "") -> Validator:
    """Accept numbers within [low, high]."""

    def check(value: Any, label: str) -> float:
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise InvalidSettingError(f"{label}: {value!r} is not a number") from None
        if not low <= number <= high:
            raise InvalidSettingError(f"{label}: {value:g}{unit} is outside the allowed {low:g}..{high:g}{unit}")
        return number

    return check


def integer_in_range(low: int, high: int) -> Validator:
    """Accept whole numbers within [low, high]."""

    def check(value: Any, label: str) -> int:
        if isinstance(value, bool) or not float(value).is_integer():
            raise InvalidSettingError(f"{label}: {value!r} is not a whole number")
        if not low <= int(value) <= high:
            raise InvalidSettingError(f"{label}: {value} is outside the allowed {low}..{high}")
        return int(value)

    return check


def one_of(allowed: Iterable[float], unit: str = "") -> Validator:
    """Accept only listed numbers (e.g. a bridge's discrete test frequencies); names the nearest."""
    values = sorted(float(v) for v in allowed)
    accepted = frozenset(values)  # membership without walking the list (a bridge frequency is checked per switch)

    def check(value: Any, label: str) -> float:
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise InvalidSettingError(f"{label}: {value!r} is not a number") from None
        if number not in accepted:
            nearest = min(values, key=lambda v: abs(v - number))
            raise InvalidSettingError(
                f"{label}: {number:g}{unit} is not supported; nearest allowed is {nearest:g}{unit} "
                f"(allowed: {', '.join(f'{v:g}' for v in values)})"
            )
        return number

    return check


def choice(mapping: Mapping[Any, Any]) -> Validator:
    """Accept a name from ``mapping`` and send its code (e.g. 'series' -> 0)."""

    def check(value: Any, label: str) -> Any:
        if value not in mapping:
            raise InvalidSettingError(f"{label}: {value!r} is not one of {', '.join(map(repr, mapping))}")
        return mapping[value]

    return check


# -- the descriptor -------------------------------------------------------------------------
class Control(Generic[T]):
    """An instrument property backed by a query and/or a set command.

    ``get_command`` is sent to read the value and ``parse`` turns the reply into
    a Python value; ``set_command`` is formatted with the validated value. With a
    ``mapping`` (name -> code), users read and write names, the wire carries codes.
    """

    def __init__(
        self,
        get_command: str | None,
        set_command: str | None,
        doc: str,
        *,
        validator: Validator | None = None,
        mapping: Mapping[Any, Any] | None = None,
        parse: Callable[[str], Any] = float,
    ) -> None:
        self.get_command = get_command
        self.set_command = set_command
        self.__doc__ = doc
        self.mapping = mapping
        self.validator = choice(mapping) if mapping is not None else validator
        self.parse = parse
        self.name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __get__(self, instrument: Instrument | None, owner: type | None = None) -> Any:
        if instrument is None:
            return self
        if self.get_command is None:
            raise AttributeError(f"{type(instrument).__name__}.{self.name} can only be set")
        reply = instrument.ask(self.get_command)
        try:
            return self.decode(reply)
        except ValueError as exc:  # a reply that is not this setting's: name instrument, command and reply
            raise instrument.fail(self.get_command, reply, f"not a {self.name} value: {exc}") from None

    def __set__(self, instrument: Instrument, value: Any) -> None:
        if self.set_command is None:
            raise AttributeError(f"{type(instrument).__name__}.{self.name} is read-only")
        code = self.encode(instrument, value)
        command = self.set_command.format(code)
        instrument.write(command)
        instrument.confirm_set(self, command, value)

    def encode(self, instrument: Instrument, value: Any) -> Any:
        """Validate a value and return what goes into the command, raising before anything is sent."""
        label = f"{instrument.name}.{self.name}"
        return self.validator(value, label) if self.validator else value

    def decode(self, reply: str) -> Any:
        """The value a reply stands for."""
        if self.mapping is None:
            return self.parse(reply)
        code = self.parse(reply)
        for name, wire in self.mapping.items():
            if wire == code:
                return name
        raise ValueError(f"{self.name}: unexpected reply {reply!r}")


class Instrument:
    """Base of every driver: a transport plus the instrument's way of reporting errors."""

    #: Human-readable model name used in messages.
    model = "instrument"

    def __init__(self, transport: Transport) -> None:
        self.transport = transport

    @property
    def name(self) -> str:
        return self.transport.name or self.model

    def write(self, command: str) -> None:
        self.transport.write(command)

    def ask(self, command: str, timeout_s: float | None = None) -> str:
        reply = self.transport.query(command, timeout_s)
        self.check_reply(command, reply)
        return reply

    def check_reply(self, command: str, reply: str) -> None:
        """Raise InstrumentError if ``reply`` is the instrument's way of refusing ``command``."""

    def confirm_set(self, control: Control[Any], command: str, value: Any) -> None:
        """Make sure a set command was accepted (read back, or ask the error queue)."""

    def close(self) -> None:
        self.transport.close()

    def fail(self, command: str, reply: str, detail: str = "") -> InstrumentError:
        return InstrumentError(self.name, command, reply, detail)


class SCPIInstrument(Instrument):
    """SCPI instruments: errors wait in a queue read with ``SYST:ERR?``."""

    def identity(self) -> str:
        return self.ask("*IDN?")

    def error_queue(self) -> list[str]:
        """Drain ``SYST:ERR?`` until it reports no error; returns the errors found."""
        errors = []
        for _ in range(32):
            reply = self.transport.query("SYST:ERR?")
            code = reply.split(",", 1)[0].strip()
            if code in ("0", "+0"):
                break
            errors.append(reply)
        return errors

    def check_errors(self, command: str) -> None:
        errors = self.error_queue()
        if errors:
            raise self.fail(command, errors[0], "; ".join(errors[1:]))

    def confirm_set(self, control: Control[Any], command: str, value: Any) -> None:
        self.check_errors(command)
