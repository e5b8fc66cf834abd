"""Waiting on a heater: control it every period, log the bridge when due, until a condition holds or time runs out."""

from __future__ import annotations

import logging
from collections.abc import Callable

from ecds_lab.errors import EcdsLabError
from ecds_lab.runner.context import RunContext
from ecds_lab.runner.steps import BridgeLog

log = logging.getLogger("ecds_lab.runner")


def regulate(run: RunContext, heater: str, *, check_interval_s: float, timeout_s: float | None,
             bridge_log: BridgeLog | None, finished: Callable[[float, dict[str, float]], bool],
             failure: str) -> None:
    """Every ``check_interval_s``: read temperatures, control the heaters, log the bridge when due, until
    ``finished(now, temperatures)``; EcdsLabError ``failure`` after ``timeout_s`` (None: no limit)."""
    start = run.clock.now()
    last_log = start - bridge_log.interval_s if bridge_log is not None else start
    while True:
        now = run.clock.now()
        temperatures = run.thermocouples.read(fresh=True)
        run.heaters.control(temperatures)
        run.observe_holds(temperatures)
        done = finished(now, temperatures)
        if bridge_log is not None and now - last_log >= bridge_log.interval_s:
            run.log_readings(bridge_log.frequencies_hz)
            last_log = now
        if done:
            log.info("%s: %.2f C after %.0f s", heater, temperatures[heater], now - start)
            return
        if timeout_s is not None and now - start > timeout_s:
            raise EcdsLabError(f"{heater} {failure} after {timeout_s:g} s (now {temperatures[heater]:.1f} C)")
        run.clock.sleep(check_interval_s)
