"""Leaving the lab safe: heater off, slide stopped, and no Ctrl-C while that happens."""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from ecds_lab.station import Station

log = logging.getLogger("ecds_lab.runner")


@contextmanager
def ctrl_c_deferred() -> Iterator[None]:
    """Ignore Ctrl-C while the lab is being made safe (only possible in the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def make_safe(station: Station, *, stop_slide: bool) -> None:
    """Heater off first (it can burn), then stop the slide; each attempted even if the other fails."""
    try:
        station.heater.all_off()
    except Exception as exc:  # the operator must hear of it, and the slide must still be stopped
        log.critical("could not switch the heater off: %s -- SWITCH IT OFF BY HAND", exc)
    if stop_slide:
        try:
            station.slide.stop()
        except Exception as exc:
            log.error("could not stop the slide: %s", exc)
