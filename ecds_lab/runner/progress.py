"""Progress and ETA from the plan's time estimate: moves, settling, readings, heating waits.

Every step gets a nominal duration and the rows it will write (:func:`estimate_plan`); a heating
wait's and a cool-down's nominal length come from the station's thermal time constants and the
steady-state criterion the run waits on (runner/thermal_time.py); heating waits are then
calibrated by the waits already finished, so the ETA converges as the run learns how fast this
lab heats. The bar (tqdm, on a terminal only) counts rows written against the rows the run will
write; :class:`PlanEstimate` is also what the live view (:mod:`ecds_lab.live`) shows.
"""

from __future__ import annotations

import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, TextIO

from tqdm import tqdm

from ecds_lab.config.experiment import MOVE_MM_PER_S, OVERHEAD_S, READING_S, format_duration, reading_s
from ecds_lab.runner.steps import (
    ConfigureBridge,
    CoolDown,
    Home,
    IdentifyPlant,
    MeasurePoint,
    Park,
    SetHeater,
    WaitSteady,
)
from ecds_lab.runner.thermal_time import cooling_s, heating_wait_s

if TYPE_CHECKING:
    from ecds_lab.clock import Clock
    from ecds_lab.runner.plan import Plan

HOME_S = 5.0
#: Categories whose nominal durations the run calibrates by what it observes.
_CALIBRATED = ("heat", "point")


@dataclass(frozen=True)
class StepEstimate:
    """One step's nominal duration (s, simulated or lab time), rows it writes, and its category."""

    seconds: float
    rows: float
    category: str  # "heat", "cool", "point" or "other"
    travel_mm: float = 0.0


def estimate_plan(plan: Plan) -> list[StepEstimate]:
    """Nominal duration and rows of every step, in order (positions and temperatures tracked along)."""
    reading = READING_S["slow"] + OVERHEAD_S
    x_mm: float | None = None
    thermal = plan.thermal
    temperature = {"coil": thermal.ambient_c, "target": thermal.ambient_c}
    out = []
    for step in plan.steps:
        if isinstance(step, ConfigureBridge):
            reading = reading_s(step.bridge)
            out.append(StepEstimate(0.5, 0, "other"))
        elif isinstance(step, MeasurePoint):
            move = abs(step.x_mm - x_mm) if step.x_mm is not None and x_mm is not None else 0.0
            moved = step.x_mm is not None and step.x_mm != x_mm
            x_mm = step.x_mm if step.x_mm is not None else x_mm
            out.append(StepEstimate(move / MOVE_MM_PER_S + (step.settle_s if moved else 0.0) + reading, 1, "point",
                                    move))
        elif isinstance(step, Park):
            move = abs(step.x_mm - x_mm) if x_mm is not None else 0.0
            x_mm = step.x_mm
            out.append(StepEstimate(move / MOVE_MM_PER_S, 0, "other", move))
        elif isinstance(step, Home):
            x_mm = None
            out.append(StepEstimate(HOME_S, 0, "other"))
        elif isinstance(step, WaitSteady):
            part = getattr(thermal, step.heater)
            seconds = heating_wait_s(step.steady, step.setpoint_c - temperature[step.heater], part)
            temperature[step.heater] = step.setpoint_c
            out.append(StepEstimate(seconds, logged_rows(step, seconds, reading), "heat"))
        elif isinstance(step, IdentifyPlant):  # baseline, the pulse to +rise_k, the record until it turns
            part = getattr(thermal, step.heater)
            seconds = 4 * step.check_interval_s + part.settling_time_constant_s
            temperature[step.heater] += step.rise_k
            out.append(StepEstimate(seconds, 0, "heat"))
        elif isinstance(step, CoolDown):
            seconds = cooling_s(temperature[step.heater], step.below_c, thermal.ambient_c,
                                getattr(thermal, step.heater), step.timeout_s)
            temperature[step.heater] = min(temperature[step.heater], step.below_c)
            out.append(StepEstimate(seconds, logged_rows(step, seconds, reading), "cool"))
        else:
            out.append(StepEstimate(0.1, 0, "other"))
    return out


def logged_rows(step: WaitSteady | CoolDown, seconds: float, reading_s: float) -> float:
    """Bridge readings logged while waiting: one per frequency every log period, the first at once."""
    if step.log is None or not step.log.frequencies_hz:
        return 0
    return (seconds // log_period_s(step, reading_s) + 1) * len(step.log.frequencies_hz)


def log_period_s(step: WaitSteady | CoolDown, reading_s: float) -> float:
    """Lab seconds from one log of a wait to the next: its log interval and one reading per frequency (0 without
    a log)."""
    if step.log is None:
        return 0.0
    return step.log.interval_s + len(step.log.frequencies_hz) * reading_s


class PlanEstimate:
    """The plan's estimate, calibrated by the steps a run has finished: remaining time and total rows."""

    def __init__(self, plan: Plan) -> None:
        self.plan = plan
        self.steps = estimate_plan(plan)
        self._observed: dict[str, list[float]] = {c: [0.0, 0.0] for c in _CALIBRATED}  # actual, nominal

    def observe(self, index: int, actual_s: float) -> None:
        """Step ``index`` took ``actual_s``: calibrate the steps of its category."""
        estimate = self.steps[index]
        if estimate.category in self._observed and estimate.seconds > 0:
            sums = self._observed[estimate.category]
            sums[0] += actual_s
            sums[1] += estimate.seconds

    def factor(self, category: str) -> float:
        """Observed / nominal duration of the category's finished steps (1 before any)."""
        actual, nominal = self._observed.get(category, (0.0, 0.0))
        return actual / nominal if nominal > 0 and actual > 0 else 1.0

    def seconds(self, index: int) -> float:
        estimate = self.steps[index]
        return estimate.seconds * self.factor(estimate.category)

    def rows(self, index: int) -> float:
        estimate = self.steps[index]
        return estimate.rows * self.factor(estimate.category) if estimate.category == "heat" else estimate.rows

    def remaining_s(self, index: int, in_step_s: float) -> float:
        """Time left when step ``index`` has run ``in_step_s`` (a step that overruns is nearly done)."""
        if index >= len(self.steps):
            return 0.0
        current = max(self.seconds(index) - in_step_s, 0.05 * self.seconds(index))
        return current + sum(self.seconds(i) for i in range(index + 1, len(self.steps)))

    def total_rows(self, index: int, rows_written: int, rows_in_step: int) -> int:
        """The rows the run will have written when it ends (at least those already written)."""
        if index >= len(self.steps):
            return rows_written
        current = max(self.rows(index) - rows_in_step, 0.0)
        return rows_written + round(current + sum(self.rows(i) for i in range(index + 1, len(self.steps))))

    def total_s(self) -> float:
        return sum(s.seconds for s in self.steps)


def summary(plan: Plan) -> str:
    """The ``--dry-run`` summary: steps by kind, readings, estimated duration, temperature range, travel."""
    steps = estimate_plan(plan)
    kinds = Counter(type(step).__name__ for step in plan.steps)
    temperatures = [t for step in plan.steps for t in (
        [step.setpoint_c] if isinstance(step, (WaitSteady, SetHeater)) and step.setpoint_c is not None
        else [step.below_c] if isinstance(step, CoolDown) else [])]
    logged = sum(s.rows for s, step in zip(steps, plan.steps, strict=True) if not isinstance(step, MeasurePoint))
    lines = ["summary:",
             "  steps: " + ", ".join(f"{count} {name}" for name, count in sorted(kinds.items())),
             f"  readings: {len(plan.points)} planned, about {int(logged)} logged while waiting on heaters; "
             f"about {len(plan.points) + int(logged)} rows in the run file, one per reading",
             f"  estimated duration: {_lab_time(sum(s.seconds for s in steps))} of lab time ({_basis(plan)})",
             "  temperatures: " + (f"{min(temperatures):g} C to {max(temperatures):g} C" if temperatures
                                   else "no heating"),
             f"  slide travel: {sum(s.travel_mm for s in steps):.1f} mm between planned positions"]
    return "\n".join(lines)


def _lab_time(seconds: float) -> str:
    """Minutes always (comparable between plans), the larger unit beside them when it reads better."""
    longer = format_duration(seconds)
    return f"{seconds / 60:.1f} min" + (f" ({longer})" if not longer.endswith(("min", " s")) else "")


def _basis(plan: Plan) -> str:
    """What the estimate assumed: the station's time constants of the heated parts the plan uses, the slide speed."""
    heated = sorted({step.heater for step in plan.steps if isinstance(step, (WaitSteady, CoolDown))})
    parts = [f"{heater}: settles with tau {getattr(plan.thermal, heater).settling_time_constant_s:g} s, "
             f"cools with {getattr(plan.thermal, heater).cooling_time_constant_s:g} s" for heater in heated]
    if heated:
        parts.append("from the station's thermal figures and the experiment's steady-state criterion")
    return "; ".join([*parts, f"slide {MOVE_MM_PER_S:g} mm/s"])


class Progress:
    """A bar of rows written against rows expected, with the plan-based ETA; silent when not ``enabled``.

    The runner calls :meth:`step_started`; a background thread refreshes the bar twice a second
    from the run file's row count and the station's clock (waits write rows rarely). Without a bar
    (not enabled, or not a terminal) nothing reads the estimate, so the per-step calls do nothing:
    a sweep makes them for every reading.
    """

    def __init__(self, plan: Plan, clock: Clock, rows: Callable[[], int], *, enabled: bool,
                 stream: TextIO | None = None) -> None:
        self._estimate = PlanEstimate(plan)
        self._clock, self._rows = clock, rows
        self._lock = threading.Lock()
        self._index, self._step_start = 0, clock.now()
        self._rows_at_step = rows()
        self._start_sim, self._start_wall = clock.now(), time.monotonic()
        self._note = ""
        self._stop = threading.Event()
        self._bar = (tqdm(total=self._estimate.total_rows(0, self._rows_at_step, 0), unit="row", desc=plan.name,
                          disable=None, dynamic_ncols=True, file=stream, mininterval=0.2,
                          bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} rows [{elapsed}{postfix}]")
                     if enabled else None)
        #: A bar is drawn (enabled, on a terminal): only then is there an estimate to keep.
        self.shown = self._bar is not None and not self._bar.disable
        self._thread: threading.Thread | None = None
        if self.shown:
            self._thread = threading.Thread(target=self._refresh_loop, name="progress", daemon=True)
            self._thread.start()

    def step_started(self, index: int) -> None:
        """Step ``index`` begins: the previous one is finished and calibrates the estimate."""
        if not self.shown:
            return
        now = self._clock.now()
        with self._lock:
            if index > self._index:
                self._estimate.observe(self._index, now - self._step_start)
            self._index, self._step_start, self._rows_at_step = index, now, self._rows()
        self._refresh()

    def point_measured(self) -> None:
        if self.shown:
            self._refresh()

    def note(self, text: str) -> None:
        """A short status beside the bar, e.g. a heater's temperature while the run waits on it."""
        self._note = text
        if self.shown:
            self._refresh()

    def eta_s(self) -> float:
        """Wall seconds left: the plan's remaining time at the pace this run keeps (lab time per wall second);
        tracked while a bar is shown."""
        now = self._clock.now()
        with self._lock:
            remaining = self._estimate.remaining_s(self._index, now - self._step_start)
        sim, wall = now - self._start_sim, time.monotonic() - self._start_wall
        return remaining * (wall / sim) if sim > 0 else remaining

    def _refresh(self) -> None:
        bar = self._bar
        if bar is None or not self.shown:
            return
        rows = self._rows()
        with self._lock:
            total = self._estimate.total_rows(self._index, rows, rows - self._rows_at_step)
        bar.total = max(total, rows)
        bar.n = rows
        left_s = self.eta_s()
        eta = time.strftime("%M:%S", time.gmtime(left_s)) if left_s < 3600 else format_duration(left_s)
        bar.set_postfix_str(f"ETA {eta}" + (f", {self._note}" if self._note else ""), refresh=False)
        bar.refresh()

    def _refresh_loop(self) -> None:
        while not self._stop.wait(0.5):
            self._refresh()

    def close(self, completed: bool = False) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        if self._bar is not None:
            if completed and not self._bar.disable:
                rows = self._rows()
                self._bar.total, self._bar.n = rows, rows
                self._bar.set_postfix_str("ETA 00:00", refresh=False)
                self._bar.refresh()
            self._bar.close()

