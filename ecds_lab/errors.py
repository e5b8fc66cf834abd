"""The exceptions ecds-lab raises, so callers can catch one family per kind of failure."""

from __future__ import annotations


class EcdsLabError(Exception):
    """Base class of every error ecds-lab raises on purpose."""


class InvalidSettingError(EcdsLabError, ValueError):
    """A value a driver refuses before anything is sent (unsupported frequency, out of range...)."""


class InstrumentError(EcdsLabError):
    """The instrument reported an error for a command it was sent."""

    def __init__(self, instrument: str, command: str, reply: str, detail: str = "") -> None:
        self.instrument = instrument
        self.command = command
        self.reply = reply
        message = f"{instrument}: command {command!r} failed with reply {reply!r}"
        if detail:
            message += f" ({detail})"
        super().__init__(message)


class TransportError(EcdsLabError):
    """The link to an instrument failed: could not open, timed out, or was closed."""


class TransportTimeout(TransportError):
    """No complete reply arrived within the transport's timeout."""


class ConfigError(EcdsLabError):
    """A station, experiment or sensor file is invalid; the message names file, field and allowed values."""


class SafetyInterlock(EcdsLabError):
    """A safety limit tripped (over-temperature, lost thermocouple); the heater has been switched off."""


class ReplayDivergence(EcdsLabError):
    """Code under replay sent a command the recording does not have at that position."""


class RunFileError(EcdsLabError):
    """A run file is missing, truncated, corrupt or of the wrong kind."""


class HeaterNotOff(EcdsLabError):
    """After switching off, the heater supply still reports an output on or drawing current."""


class ReplyFormatError(InstrumentError):
    """A reply that does not have the format its command promises (cut short, extra line, out of range)."""
