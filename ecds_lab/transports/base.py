"""The line-oriented link every driver talks through.

Termination, timeouts, pacing between commands and transcript recording live
here once, so drivers only say *what* to send. Concrete links (pyserial, pyvisa,
replay) implement three primitives: send bytes, receive one line, close.
"""

from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from collections.abc import Iterable

from ecds_lab.clock import Clock, WallClock
from ecds_lab.errors import EcdsLabError, TransportError, TransportTimeout
from ecds_lab.transports.transcript import ERROR, RECEIVED, SENT, STALE, Transcript

log = logging.getLogger("ecds_lab.link")

#: At most this many waiting lines are discarded before one query (a link that chatters without end
#: would otherwise hold the query back for ever; what is left fails the reply's format check).
MAX_STALE_LINES = 64


class Transport(ABC):
    """A text link to one instrument: ``write``, ``read_line``, ``query``.

    ``min_interval_s`` enforces a pause between consecutive commands (the HM8118
    handles one command at a time and needs ~0.15-0.2 s between them); the pause
    is taken on ``clock`` so simulated runs do not wait in real time.

    ``query`` first discards every line already waiting on the link (an unsolicited line, a reply
    left from an earlier exchange), so that only a line arriving after the command can be its reply;
    each is recorded in the transcript as kind ``stale``, logged, and summed up by ``stale_note``.
    ``write_replies`` names the lines an instrument sends in answer to a command that otherwise answers
    nothing (the HM8118's ``ERROR`` for a refused setting): such a line is not stale but the answer to
    the write before the query, so it and what follows it are left for the query to read.
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
        write_replies: Iterable[str] = (),
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
        self.write_replies = frozenset(write_replies)
        #: A waiting line left unread by ``discard_waiting`` (one of ``write_replies``): the next read returns it.
        self._held: str | None = None
        #: Lines discarded as stale before a query, and the first of them: (clock_s, line, the query).
        self.stale_count = 0
        self.first_stale: tuple[float, str, str] | None = None

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

    def _waiting_line(self) -> str | None:
        """A whole line already received and not yet read, taken without waiting; None when there is none or
        the link cannot tell without waiting (then nothing is discarded before a query)."""
        return None

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
        line: str | None = self._held
        if line is not None:
            self._held = None
        else:
            line = self._receive_line(timeout)
        if line is None:
            self._log(ERROR, "timeout")
            raise TransportTimeout(f"{self.name}: no reply within {timeout:g} s")
        if self.transcript is not None:  # _log, inline: this runs for every line of every reading
            self.transcript.record(self.clock.now(), RECEIVED, line)
        return line

    def query(self, command: str, timeout_s: float | None = None) -> str:
        """Send a command and return the one-line reply (waiting up to ``timeout_s`` if given). Lines waiting
        on the link when the command goes out (after the pacing pause) are discarded first: never the reply."""
        if self.min_interval_s > 0:
            self._pace()
        self.discard_waiting(command)
        self._send_logged(command, (command + self.write_termination).encode("ascii"))
        return self.read_line(timeout_s)

    def discard_waiting(self, command: str = "") -> list[str]:
        """Read and discard the lines already waiting (before ``command`` is sent); each is recorded in the
        transcript as ``stale`` and logged. Returns them."""
        if self._closed:
            self._check_open()
        if self._held is not None:
            return []
        line = self._waiting_line()
        if line is None:  # the usual case: nothing waiting
            return []
        discarded: list[str] = []
        while line is not None:
            if line.strip() in self.write_replies:  # the answer to the write before this query: the query reads it
                self._held = line
                break
            now = self.clock.now()
            self._log(STALE, line)
            log.warning("%s: discarded a line waiting on the link before %r (not taken as its reply): %r",
                        self.name, command, line)
            if self.first_stale is None:
                self.first_stale = (now, line, command)
            self.stale_count += 1
            discarded.append(line)
            line = self._waiting_line() if len(discarded) < MAX_STALE_LINES else None
        return discarded

    def stale_note(self) -> str | None:
        """One line on the stale lines this link discarded (for the run's notes), or None if there were none."""
        if self.first_stale is None:
            return None
        at, line, command = self.first_stale
        return (f"{self.name}: {self.stale_count} stale line(s) found waiting on the link before a query were "
                f"discarded, not taken as replies (first: {line!r} before {command!r} at {at:.3f} s; the "
                "transcript records each as kind 'stale')")

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
