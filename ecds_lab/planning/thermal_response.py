"""How the campaign's lab answered its heaters, for predicting a planned wait: how long it lasts and the heated
part's temperature along it.

Two physical pictures, each read off the waits the campaign recorded (``planning.recorded_waits``):

- **A steady wait** is the heater's regulation answering a setpoint step. The loop (PI gains, plant) is the same
  for every wait of that part on the station, and a linear loop's answer to a step is the step times one shape
  (superposition): the remaining error as a fraction of the step against time. The planned wait follows the shape
  of the recorded wait of the same part and direction whose step is nearest in ratio (a step the heater meets at
  full power, or a much smaller one, has a somewhat other shape: the supply's limit is not linear); past the
  recorded span the error left falls with the station's declared settling time constant. How long it lasts is
  the runner's own steady-state judgement (``runner.steady_state.SteadinessWindow``, checked every interval) on
  that trajectory, so a long window (a hold of an hour) and an overshoot are judged as the run judges them.
- **A cool-down** is free cooling towards the room (its ambient thermocouple): first order (Newton), its time
  constant from the slope of ln(T - room) against time over the recorded cool-downs of that part, after the lag
  with which the thermocouple starts to fall.

Where the campaign recorded no such wait of the part, the plan's estimate from the station's declared figures
stands (``runner/thermal_time.py``; ``planning.conditions``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ecds_lab.config.station import ThermalConfig
from ecds_lab.planning.recorded_waits import RecordedWait
from ecds_lab.runner.steady_state import SteadinessWindow, SteadyState

#: A cool-down's log counts in the fit while its excess over the room is at least this (K): below it the
#: thermocouple's resolution and the room's drift dominate the logarithm.
MIN_EXCESS_K = 1.0
#: A steady wait's shape is kept only for a step at least this large (K): a smaller one is mostly noise.
MIN_STEP_K = 0.5


@dataclass(frozen=True)
class WaitShape:
    """A recorded steady wait as its part's response: the step (K, setpoint minus start) and the error left as a
    fraction of it at times from the wait's start."""

    step_k: float
    times_s: np.ndarray
    fraction: np.ndarray

    def at(self, t_s: float | np.ndarray, tail_tau_s: float) -> np.ndarray:
        """The error fraction at ``t_s``; past the recorded end, what was left falls with ``tail_tau_s``."""
        t = np.asarray(t_s, float)
        inside = np.interp(t, self.times_s, self.fraction)
        end = self.times_s[-1]
        return np.where(t <= end, inside, self.fraction[-1] * np.exp(-(t - end) / tail_tau_s))


@dataclass(frozen=True)
class PlannedWait:
    """A planned wait predicted from the campaign: how long it lasts (s) and its part's temperature along it."""

    seconds: float
    start_c: float
    goal_c: float
    shape: WaitShape | None = None
    tail_tau_s: float = 1.0
    #: free cooling's (time constant, lag), s, when the wait is a cool-down
    cooling: tuple[float, float] | None = None

    def temperature_c(self, t_s: float) -> float:
        """The part's temperature ``t_s`` after the wait began."""
        if self.shape is not None:
            return float(self.goal_c + (self.start_c - self.goal_c) * self.shape.at(t_s, self.tail_tau_s))
        assert self.cooling is not None
        tau, lag = self.cooling
        return self.goal_c + (self.start_c - self.goal_c) * math.exp(-max(t_s - lag, 0.0) / tau)


@dataclass(frozen=True)
class ThermalResponse:
    """The campaign's recorded responses per heated part, beside the station's declared figures."""

    declared: ThermalConfig
    shapes: dict[str, list[WaitShape]] = field(default_factory=dict)
    #: per part: free cooling's time constant and lag (s) and the room it cooled towards (C)
    cooling_fits: dict[str, tuple[float, float, float]] = field(default_factory=dict)

    @classmethod
    def of(cls, waits: Sequence[RecordedWait], declared: ThermalConfig) -> ThermalResponse:
        """The shapes of the recorded steady waits and the cooling time constant fitted to the cool-downs."""
        shapes: dict[str, list[WaitShape]] = {}
        for wait in waits:
            if wait.cooling or wait.duration_s is None or abs(wait.goal_c - wait.start_c) < MIN_STEP_K:
                continue
            step = wait.goal_c - wait.start_c
            logs = wait.times_s <= wait.duration_s  # the wait's own logs; it held its last one to its end
            times = np.append(wait.times_s[logs], wait.duration_s)
            fraction = (wait.goal_c - wait.temps_c[logs]) / step
            fraction = np.append(fraction, fraction[-1])
            shapes.setdefault(wait.heater, []).append(WaitShape(step, times, fraction))
        cooling = {heater: fit for heater in {w.heater for w in waits if w.cooling}
                   if (fit := cooling_fit([w for w in waits if w.cooling and w.heater == heater])) is not None}
        return cls(declared, shapes, cooling)

    def heating(self, heater: str, start_c: float, setpoint_c: float, steady: SteadyState) -> PlannedWait | None:
        """The wait for ``steady`` at ``setpoint_c`` from ``start_c``, from the recorded wait of the part in the
        same direction with the nearest step; None when the campaign recorded none."""
        step = setpoint_c - start_c
        alike = [s for s in self.shapes.get(heater, []) if s.step_k * step > 0]
        if not alike:
            return None
        shape = min(alike, key=lambda s: abs(math.log(s.step_k / step)))
        tail = getattr(self.declared, heater).settling_time_constant_s
        wait = PlannedWait(0.0, start_c, setpoint_c, shape, tail)
        return PlannedWait(steady_after_s(steady, setpoint_c, wait.temperature_c), start_c, setpoint_c, shape, tail)

    def cooling(self, heater: str, start_c: float, below_c: float, timeout_s: float | None) -> PlannedWait | None:
        """Free cooling from ``start_c`` until below ``below_c``, towards the room the recorded cool-downs fell
        towards (the lab's ambient thermocouple); None without a fitted time constant for the part."""
        if heater not in self.cooling_fits:
            return None
        tau, lag, room_c = self.cooling_fits[heater]
        if start_c <= below_c:
            seconds = 0.0
        elif below_c <= room_c:
            seconds = timeout_s if timeout_s is not None else math.inf
        else:
            seconds = lag + tau * math.log((start_c - room_c) / (below_c - room_c))
            seconds = min(seconds, timeout_s) if timeout_s is not None else seconds
        if not math.isfinite(seconds):
            return None  # it never gets there and nothing ends it: the plan's estimate says what it counts then
        return PlannedWait(seconds, start_c, room_c, cooling=(tau, lag))

    def describe(self) -> list[str]:
        """One line per heated part the campaign informs: what it recorded and what the prediction takes from it."""
        lines = []
        for heater in sorted({*self.shapes, *self.cooling_fits}):
            part = getattr(self.declared, heater)
            steps = ", ".join(f"{s.step_k:+.1f} K" for s in self.shapes.get(heater, []))
            settle = f"settles as its recorded steps ({steps})" if steps else (
                f"settles with the declared tau {part.settling_time_constant_s:g} s")
            tau, lag, _ = self.cooling_fits.get(heater, (None, None, None))
            cool = (f"cools with tau {tau:.0f} s after a lag of {lag:.0f} s (recorded; declared tau "
                    f"{part.cooling_time_constant_s:g} s)" if tau is not None
                    else f"cools with the declared tau {part.cooling_time_constant_s:g} s")
            lines.append(f"{heater}: {settle}; {cool}")
        return lines


def cooling_fit(waits: Sequence[RecordedWait]) -> tuple[float, float, float] | None:
    """Free cooling's (time constant s, lag s, room C): ln(T - room) against time is a straight line of slope
    -1/tau over every log of the cool-downs (each its own intercept) while the excess is at least MIN_EXCESS_K; the
    lag is how much later than the wait's start that line meets the starting excess (the heat still flowing from the
    heater to the thermocouple when it is switched off), averaged over the cool-downs, never below 0; the room is
    the ambient thermocouple's, averaged over them. None without a falling cool-down."""
    fits, used = [], []
    for wait in waits:
        excess = wait.temps_c - wait.ambient_c
        keep = excess >= MIN_EXCESS_K
        if np.count_nonzero(keep) >= 3 and keep[0]:
            fits.append((wait.times_s[keep], np.log(excess[keep])))
            used.append(wait)
    sxx = sum(float(np.sum((t - t.mean()) ** 2)) for t, _ in fits)
    sxy = sum(float(np.sum((t - t.mean()) * (y - y.mean()))) for t, y in fits)
    if not fits or sxx <= 0 or not sxy < 0:
        return None
    tau = -sxx / sxy
    lags = [tau * (float(y.mean() + t.mean() / tau) - float(y[0])) for t, y in fits]
    room = float(np.mean([w.ambient_c for w in used]))
    return tau, max(float(np.mean(lags)), 0.0), room


def steady_after_s(steady: SteadyState, setpoint_c: float, temperature_c: Callable[[float], float]) -> float:
    """When the runner's steady-state judgement (checked every ``check_interval_s`` from the wait's start) first
    holds on the trajectory ``temperature_c(t)``; the timeout (or a day) when it never does."""
    window = SteadinessWindow(steady, setpoint_c)
    limit = steady.timeout_s if steady.timeout_s is not None else 86400.0
    t = 0.0
    while t < limit:
        if window.add(t, temperature_c(t)):
            return t
        t += steady.check_interval_s
    return limit
