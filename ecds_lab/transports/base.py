"""The line-oriented link every driver talks through.

Termination, timeouts, pacing between commands and transcript recording live
here once, so drivers only say *what* to send. Concrete links (pyserial, pyvisa,
replay) implement three primitives: send bytes, receive one line, close.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

from ecds_lab.clock import Clock, WallClock
from ecds_lab.errors import EcdsLabError, TransportError, TransportTimeout
from ecds_lab.transports.transcript import ERROR, RECEIVED, SENT, Transcript


class Transport(ABC):
    """A text link to one instrument: ``write``, ``read_line``, ``query``.

    ``min_interval_s`` enforces a pause between consecutive commands (the HM8118
    handles one command at a time and needs ~0.15-0.2 s between them); the pause
    is taken on ``clock`` so simulated runs do not wait in real time.
    """

    def __init__(
        self,
        name: str,
        *,
        write_termination: str = "\n",
        read_termination: str = "\n",
        timeout_s: float = 2.0,
        min_interval_s: float = 0.0,
        clock: Clock | None = None,
        record: bool = True,
    ) -> None:
        self.name = name
        self.write_termination = write_termination
        self.read_termination = read_termination
        self.timeout_s = timeout_s
        self.min_interval_s = min_interval_s
        self.clock: Clock = clock or WallClock()
        self.transcript: Transcript | None = Transcript(name) if record else None
        self._last_command_at: float | None = None
        self._closed = False

    # -- primitives a concrete link provides -------------------------------------------------
    @abstractmethod
    def _send(self, data: bytes) -> None:
        """Put bytes on the wire."""

    @abstractmethod
    def _receive_line(self, timeout_s: float) -> str | None:
        """One line without its termination, or None when ``timeout_s`` passed first."""

    @abstractmethod
    def _close(self) -> None:
        """Release the port or resource."""

    # -- what drivers use --------------------------------------------------------------------
    def write(self, command: str) -> None:
        """Send one command with the write termination, after the pacing pause."""
        if self.min_interval_s > 0:
            self._pace()
        self._send_logged(command, (command + self.write_termination).encode("ascii"))

    def write_bytes(self, data: bytes) -> None:
        """Send raw bytes without termination or pacing (real-time commands such as GRBL's ``?``)."""
        self._send_logged(data.decode("latin-1"), data)

    def read_line(self, timeout_s: float | None = None) -> str:
        """The next line from the instrument; raises TransportTimeout if none arrives in time.

        ``timeout_s`` replaces the link's timeout for this read (a slow measurement, a compensation run).
        """
        if self._closed:
            self._check_open()
        timeout = self.timeout_s if timeout_s is None else timeout_s
        line = self._receive_line(timeout)
        if line is None:
            self._log(ERROR, "timeout")
            raise TransportTimeout(f"{self.name}: no reply within {timeout:g} s")
        if self.transcript is not None:  # _log, inline: this runs for every line of every reading
            self.transcript.record(self.clock.now(), RECEIVED, line)
        return line

    def query(self, command: str, timeout_s: float | None = None) -> str:
        """Send a command and return the one-line reply (waiting up to ``timeout_s`` if given)."""
        self.write(command)
        return self.read_line(timeout_s)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._close()

    def __enter__(self) -> Transport:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- internals ---------------------------------------------------------------------------
    def _pace(self) -> None:
        """Wait on the clock until ``min_interval_s`` has passed since the previous command."""
        if self.min_interval_s <= 0:
            return
        now = self.clock.now()
        if self._last_command_at is not None:
            wait = self._last_command_at + self.min_interval_s - now
            if wait > 0:
                self.clock.sleep(wait)
        self._last_command_at = self.clock.now()

    def _send_logged(self, text: str, data: bytes) -> None:
        if self._closed:
            self._check_open()
        if self.transcript is not None:  # _log, inline: this runs for every command of every reading
            self.transcript.record(self.clock.now(), SENT, text)
        try:
            self._send(data)
        except EcdsLabError:  # already ours and named (a link's TransportError, a replay's ReplayDivergence)
            raise
        except Exception as exc:  # a serial/VISA library error becomes ours, with the instrument named
            self._log(ERROR, str(exc))
            raise TransportError(f"{self.name}: sending {text!r} failed: {exc}") from exc

    def _log(self, kind: str, text: str) -> None:
        if self.transcript is not None:
            self.transcript.record(self.clock.now(), kind, text)

    def _check_open(self) -> None:
        if self._closed:
            raise TransportError(f"{self.name}: link is closed")
