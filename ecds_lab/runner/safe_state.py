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
def _handled_by(handler: Any, signals: tuple[signal.Signals, ...], *, ignore_stops: bool) -> Iterator[None]:
    """``signals`` handled by ``handler`` for the body, and afterwards every handler as it was, whenever a stop signal
    lands: each is recorded before it is replaced, all inside the ``try``. A stop whose handler runs while they are
    replaced (one pending, or one not yet replaced) is ignored and the replacing goes on if ``ignore_stops``, else
    raised once those replaced so far are restored; one landing while they are restored is raised once all are."""
    previous: dict[signal.Signals, Any] = {}
    try:
        while True:
            try:
                for sig in signals:
                    previous.setdefault(sig, signal.getsignal(sig))
                    signal.signal(sig, handler)
                break
            except (KeyboardInterrupt, StopSignal):
                if not ignore_stops:
                    raise
        yield
    finally:
        _restore(previous)


def _restore(previous: dict[signal.Signals, Any]) -> None:
    """Every handler in ``previous`` set again, also when a stop lands meanwhile; that stop is raised at the end."""
    landed: BaseException | None = None
    for sig, handler in previous.items():
        while True:
            try:
                signal.signal(sig, handler)
                break
            except (KeyboardInterrupt, StopSignal) as stop:  # set again: setting a handler twice is harmless
                landed = landed or stop
    if landed is not None:
        raise landed


@contextmanager
def stop_signals_raise() -> Iterator[None]:
    """While a run executes, SIGTERM and SIGHUP raise StopSignal (main thread only; elsewhere a no-op)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    with _handled_by(_raise_stop, STOP_SIGNALS, ignore_stops=False):
        yield


@contextmanager
def ctrl_c_deferred() -> Iterator[None]:
    """Ignore Ctrl-C, SIGTERM and SIGHUP while the lab is made safe and the file closed (main thread only).

    A stop signal whose handler runs while the handlers are set aside is ignored as the ones after it: its
    exception could otherwise skip the body, which makes the lab safe (``runner.Runner``)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    with _handled_by(signal.SIG_IGN, _DEFERRED, ignore_stops=True):
        yield


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
