"""Execute a plan on a station, writing every reading to the run file as it is taken.

The runner walks the steps a run needs (:mod:`~ecds_lab.runner.resume`), hands each to its
handler (:mod:`~ecds_lab.runner.handlers`), and owns the ending: on any failure or Ctrl-C the
lab is made safe (:mod:`~ecds_lab.runner.safe_state`) and the status is returned for the run file.
Interlocks (:mod:`~ecds_lab.runner.interlocks`) stop a run by raising inside a step.
"""

from __future__ import annotations

import gc
import logging
import signal
from collections.abc import Iterator
from contextlib import contextmanager

from ecds_lab.runner.context import RunContext
from ecds_lab.runner.handlers import handler_for
from ecds_lab.runner.plan import Plan
from ecds_lab.runner.progress import Progress
from ecds_lab.runner.resume import steps_to_run
from ecds_lab.runner.safe_state import StopSignal, ctrl_c_deferred, make_safe, signal_name
from ecds_lab.runner.steps import SetHeater
from ecds_lab.station import Station
from ecds_lab.storage.run_file import RunWriter

log = logging.getLogger("ecds_lab.runner")


class Runner:
    """Runs one plan; ``done`` holds planned point numbers a previous attempt already measured."""

    def __init__(self, station: Station, plan: Plan, writer: RunWriter, *, done: set[int] | None = None,
                 time_offset_s: float = 0.0, progress: bool = True) -> None:
        self.station = station
        self.plan = plan
        self.writer = writer
        self.done = done or set()
        self.t0 = station.clock.now() - time_offset_s
        self.progress = progress
        #: The signal that stopped the run (SIGINT for Ctrl-C), or None.
        self.stopped_by: int | None = None
        #: What the run tracked besides its rows (holds, identified gains, notes), once it ran.
        self.context: RunContext | None = None

    def run(self) -> tuple[str, str]:
        """Execute every step; returns (status, error message). The lab is left safe whatever happens."""
        plan = self.plan
        progress = Progress(plan, self.station.clock, lambda: self.writer.rows, enabled=self.progress)
        context = RunContext(self.station, self.writer, progress, t0=self.t0,
                             heats=any(isinstance(s, SetHeater) for s in plan.steps),
                             coil_in_air=plan.coil_in_air)
        self.context = context
        status, error = "completed", ""
        try:
            with _startup_objects_frozen():
                for index, step in steps_to_run(plan, self.done):
                    context.step_index = index
                    progress.step_started(index)
                    if log.isEnabledFor(logging.INFO):  # describe a step only for a listener: runs have many thousand
                        log.info("%s", step.describe())
                    handler_for(step)(context, step)
        except KeyboardInterrupt:
            status, error = "aborted", "interrupted by the operator (Ctrl-C)"
            self.stopped_by = signal.SIGINT
        except StopSignal as stop:
            status, error = "aborted", f"stopped by {signal_name(stop.signum)}"
            self.stopped_by = stop.signum
        except Exception as exc:  # any failure: record it, make the lab safe, keep every point
            status, error = "failed", f"{type(exc).__name__}: {exc}"
        finally:
            with ctrl_c_deferred():
                unsafe = make_safe(self.station, stop_slide=status != "completed")
                progress.close(completed=status == "completed")
        if unsafe:  # a heater that may still be on outranks every other ending
            status, error = "failed", unsafe + (f" (after: {error})" if error else "")
        if error:
            log.error("run %s: %s", status, error)
        return status, error


@contextmanager
def _startup_objects_frozen() -> Iterator[None]:
    """Keeps the objects alive when the steps start (station, plan, the libraries' module state: about 100,000)
    out of the cyclic garbage collector's full collections while the steps run; each full collection, about one
    per 10,000 readings, would otherwise walk them all again (tens of ms). ``gc.freeze``; ``gc.unfreeze`` at the
    end hands them back to the collector (one of them that dies in a reference cycle during the run is freed
    after it; objects made during the run are collected as usual). A process that froze objects itself
    (``gc.get_freeze_count()`` above 0) is left as it is: unfreezing would undo its freeze."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()

