"""Leaving the lab safe: heater off and verified off, slide stopped, and no signal while that happens.

Ctrl-C, SIGTERM (``kill``, a systemd stop) and SIGHUP (a closed SSH session) all take one path:
the signal becomes a :class:`StopSignal` inside the run, the runner makes the lab safe and
records status ``aborted`` naming the signal, and the command line exits 128 + the signal number.
"""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import TYPE_CHECKING, Any

from ecds_lab.errors import HeaterNotOff

if TYPE_CHECKING:  # the command line imports StopSignal for every command: no serial/VISA stack for a fit
    from ecds_lab.station import Station

log = logging.getLogger("ecds_lab.runner")

#: The signals that stop a run the way Ctrl-C does (SIGINT arrives as KeyboardInterrupt).
#: Windows has no SIGHUP: there only SIGTERM (and Ctrl-C) stop a run.
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP")
                                                 if hasattr(signal, name))
_DEFERRED: tuple[signal.Signals, ...] = (signal.SIGINT, *STOP_SIGNALS)


class StopSignal(BaseException):
    """SIGTERM or SIGHUP arrived during a run; a BaseException so that no ``except Exception`` swallows it."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        super().__init__(signal_name(signum))


def signal_name(signum: int) -> str:
    """SIGTERM, SIGHUP, SIGINT..."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def exit_code(signum: int) -> int:
    """What shells expect from a process stopped by a signal: 128 + its number (130 for Ctrl-C)."""
    return 128 + int(signum)


def _raise_stop(signum: int, _frame: FrameType | None) -> None:
    raise StopSignal(signum)


@contextmanager
def stop_signals_raise() -> Iterator[None]:
    """While a run executes, SIGTERM and SIGHUP raise StopSignal (main thread only; elsewhere a no-op)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.signal(sig, _raise_stop) for sig in STOP_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


@contextmanager
def ctrl_c_deferred() -> Iterator[None]:
    """Ignore Ctrl-C, SIGTERM and SIGHUP while the lab is made safe and the file closed (main thread only).

    The handlers are set aside one at a time, and a stop signal whose handler runs meanwhile (one pending, or one
    not yet ignored) is ignored as the ones after it: its exception could otherwise leave the handlers set aside
    so far ignored for good and skip the body, which makes the lab safe (``runner.Runner``)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous: dict[signal.Signals, Any] = {}  # each handler as it was, recorded before it is replaced
    try:
        while True:
            try:
                for sig in _DEFERRED:
                    previous.setdefault(sig, signal.getsignal(sig))
                    signal.signal(sig, signal.SIG_IGN)
                break
            except (KeyboardInterrupt, StopSignal):  # a stop while they were set aside: ignored, as those after it
                continue
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def heater_outputs(station: Station) -> tuple[int, ...]:
    """The supply outputs wired to heaters (the ones an operator must switch off by hand if all else fails)."""
    wiring = station.config.heaters
    return tuple(sorted({wiring.target_output, wiring.coil_output}))


def make_safe(station: Station, *, stop_slide: bool) -> str:
    """Heater off first (it can burn) and verified off, then stop the slide; each attempted even if the
    other fails. Returns "" when the lab is safe, else the loud message the run must end with."""
    problem = ""
    outputs = heater_outputs(station)
    by_hand = f"SWITCH OFF HEATER SUPPLY OUTPUT(S) {', '.join(map(str, outputs))} BY HAND"
    try:
        station.heater.all_off()
        verify = getattr(station.heater, "verify_off", None)
        if verify is not None:
            verify(outputs)
    except HeaterNotOff as exc:
        problem = f"heater not confirmed off: {exc} -- {by_hand}"
    except Exception as exc:  # the operator must hear of it, and the slide must still be stopped
        problem = f"heater supply did not confirm switching off ({type(exc).__name__}: {exc}) -- {by_hand}"
    if problem:
        log.critical("%s", problem)
    if stop_slide:
        try:
            station.slide.stop()
        except Exception as exc:
            log.error("could not stop the slide: %s", exc)
    return problem
