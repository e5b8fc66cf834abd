"""Execute a plan on a station, writing every reading to the run file as it is taken.

The runner owns safety: interlocks while heating (over-temperature, lost or open
thermocouple), and the safe state on any failure or Ctrl-C (heater off, slide
stopped, run file closed with its status). A second Ctrl-C cannot interrupt that.
"""

from __future__ import annotations

import logging
import math
import signal
import threading
import time
from collections import deque
from contextlib import contextmanager
from typing import Callable, Iterator

from tqdm import tqdm

from ecds_lab.data.columns import LOGGED_POINT, PLANNED_POINT
from ecds_lab.errors import EcdsLabError, InstrumentError, SafetyInterlock, TransportError
from ecds_lab.instruments.interfaces import BridgeSettings
from ecds_lab.runner.heater_control import HeaterGoal, PowerLoop, volts_for_power
from ecds_lab.runner.plan import (
    ConfigureBridge,
    ConfigureScanner,
    CoolDown,
    Home,
    MeasurePoint,
    Park,
    Plan,
    SetHeater,
    Step,
    WaitSteady,
)
from ecds_lab.station import Station
from ecds_lab.storage.run_file import RunWriter

log = logging.getLogger("ecds_lab.runner")

#: Temperatures and heater powers older than this (simulated or wall seconds) are read again.
READING_MAX_AGE_S = 2.0


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


class Runner:
    """Runs one plan; ``done`` holds planned point numbers a previous attempt already measured."""

    def __init__(self, station: Station, plan: Plan, writer: RunWriter, *, done: set[int] | None = None,
                 time_offset_s: float = 0.0, progress: bool = True) -> None:
        self.station = station
        self.plan = plan
        self.writer = writer
        self.done = done or set()
        self.clock = station.clock
        self.t0 = self.clock.now() - time_offset_s
        self.progress = progress
        wiring = station.config.heaters
        self.outputs = {"target": wiring.target_output, "coil": wiring.coil_output}
        self.heater_ohm = {"target": wiring.target_heater_ohm, "coil": wiring.coil_heater_ohm}
        safety = station.config.safety
        self.max_power_w = {h: min(safety.heater_max_voltage_v ** 2 / r, safety.heater_max_voltage_v
                                   * safety.heater_max_current_a) for h, r in self.heater_ohm.items()}
        self.goals = {"target": HeaterGoal(), "coil": HeaterGoal()}
        self.loops = {h: PowerLoop(self.max_power_w[h]) for h in self.goals}
        self.measure_heaters = any(isinstance(s, SetHeater) for s in plan.steps)
        self.coil_in_air = bool(plan.points) and all(p.in_air for p in plan.points)
        self.x_mm: float | None = None
        self.readback_mm = math.nan
        self.direction = 0
        self.temperatures: dict[str, float] = {}
        self.temperatures_at = -math.inf
        self.powers = {"target": math.nan, "coil": math.nan}
        self.powers_at = -math.inf
        self.step_index = -1
        self._bar: tqdm | None = None

    # -- the run ----------------------------------------------------------------------------
    def run(self) -> tuple[str, str]:
        """Execute every step; returns (status, error message). The lab is left safe whatever happens."""
        if self.progress:  # a bar on a terminal; tqdm turns itself off when output is not one
            todo = sum(1 for s in self.plan.points if s.point not in self.done)
            self._bar = tqdm(total=todo, unit="pt", desc=self.plan.name, disable=None, dynamic_ncols=True)
        status, error = "completed", ""
        try:
            for index, step in self._steps_to_run():
                self.step_index = index
                self._execute(step)
        except KeyboardInterrupt:
            status, error = "aborted", "interrupted by the operator (Ctrl-C)"
        except Exception as exc:  # any failure: record it, make the lab safe, keep every point
            status, error = "failed", f"{type(exc).__name__}: {exc}"
        finally:
            with ctrl_c_deferred():
                self._make_safe(stop_slide=status != "completed")
                if self._bar is not None:
                    self._bar.close()
        if error:
            log.error("run %s: %s", status, error)
        return status, error

    def _steps_to_run(self) -> Iterator[tuple[int, Step]]:
        """The steps in order; when resuming, only the state-setting steps before the first missing point."""
        steps = self.plan.steps
        first = next((i for i, s in enumerate(steps) if isinstance(s, MeasurePoint) and s.point not in self.done),
                     len(steps))
        last_of_kind: dict[tuple[str, str], int] = {}
        for i, step in enumerate(steps[:first]):
            if isinstance(step, (SetHeater, WaitSteady, CoolDown)):
                last_of_kind[(type(step).__name__ if not isinstance(step, CoolDown) else "WaitSteady",
                              step.heater)] = i
            elif isinstance(step, Park):
                last_of_kind[("Park", "")] = i
        replay = set(last_of_kind.values())
        for i, step in enumerate(steps):
            if i < first and not isinstance(step, (ConfigureBridge, ConfigureScanner, Home)) and i not in replay:
                continue
            if isinstance(step, MeasurePoint) and step.point in self.done:
                continue
            yield i, step

    def _execute(self, step: Step) -> None:
        if log.isEnabledFor(logging.INFO):  # describe a step only for a listener: runs have many thousand
            log.info("%s", step.describe())
        if isinstance(step, ConfigureBridge):
            b = step.bridge
            self.station.bridge.configure(BridgeSettings(b.function, b.circuit, b.voltage_v, b.speed, b.averages))
        elif isinstance(step, ConfigureScanner):
            self.station.scanner.configure()
        elif isinstance(step, Home):
            self.station.slide.home()
            self.x_mm = None
        elif isinstance(step, Park):
            self._move(step.x_mm)
        elif isinstance(step, MeasurePoint):
            self._measure_point(step)
        elif isinstance(step, SetHeater):
            self._set_heater(step)
        elif isinstance(step, WaitSteady):
            self._wait_steady(step)
        elif isinstance(step, CoolDown):
            self._cool_down(step)
        else:
            raise EcdsLabError(f"unknown step {step!r}")

    # -- points -------------------------------------------------------------------------------
    def _move(self, x_mm: float) -> None:
        if self.x_mm == x_mm:
            return
        self.direction = self.station.slide.move_to(x_mm * 1e-3)
        self.readback_mm = self.station.slide.position_m() * 1e3
        self.x_mm = x_mm

    def _measure_point(self, step: MeasurePoint) -> None:
        if step.x_mm is not None and step.x_mm != self.x_mm:
            self._move(step.x_mm)
            self.clock.sleep(step.settle_s)
        self._record(step.freq_hz, PLANNED_POINT, step)
        if self._bar is not None:
            self._bar.update(1)

    def _record(self, freq_hz: float, kind: int, step: MeasurePoint | None = None) -> None:
        """One bridge reading with the temperatures and heater powers of the moment."""
        self.station.bridge.set_frequency(freq_hz)
        reading = self.station.bridge.measure()
        temperatures = self._temperatures()
        powers = self._heater_powers()
        in_air = step.in_air if step is not None else self.coil_in_air
        self.writer.append({
            "time_s": self.clock.now() - self.t0, "wall_time_s": time.time(), "step": self.step_index,
            "point": step.point if step is not None and kind == PLANNED_POINT else -1, "kind": kind,
            "sweep": step.sweep if step else -1, "repeat": step.repeat if step else 0,
            "reading": step.reading if step else 0,
            "x_commanded_mm": math.inf if in_air else (self.x_mm if self.x_mm is not None else math.nan),
            "x_readback_mm": self.readback_mm, "direction": self.direction, "freq_hz": freq_hz,
            "t_coil_c": temperatures.get("coil", math.nan), "t_target_c": temperatures.get("target", math.nan),
            "t_ambient_c": temperatures.get("ambient", math.nan),
            "target_heater_w": powers["target"], "coil_heater_w": powers["coil"],
            "ls_h": reading.main, "rs_ohm": reading.secondary,
        })

    # -- temperatures and interlocks ------------------------------------------------------------
    def _temperatures(self, fresh: bool = False) -> dict[str, float]:
        if not fresh and self.clock.now() - self.temperatures_at < READING_MAX_AGE_S:
            return self.temperatures
        try:
            temperatures = self.station.scanner.read_temperatures_c()
        except (InstrumentError, TransportError) as exc:
            if any(g.active for g in self.goals.values()):
                raise SafetyInterlock(f"thermocouple lost while heating, heater switched off: {exc}") from exc
            raise
        limits = self.station.config.safety.max_temperature_c
        for name, value in temperatures.items():
            if name in limits and value > limits[name]:
                raise SafetyInterlock(f"{name} thermocouple reads {value:.1f} C, above the {limits[name]:g} C limit;"
                                      " heater switched off")
        self.temperatures, self.temperatures_at = temperatures, self.clock.now()
        return temperatures

    def _heater_powers(self) -> dict[str, float]:
        if not self.measure_heaters or self.clock.now() - self.powers_at < READING_MAX_AGE_S:
            return self.powers
        for heater, output in self.outputs.items():
            volts, amps = self.station.heater.read_back(output)
            self.powers[heater] = volts * amps
        self.powers_at = self.clock.now()
        return self.powers

    # -- heating ---------------------------------------------------------------------------------
    def _set_heater(self, step: SetHeater) -> None:
        self.goals[step.heater] = HeaterGoal(step.setpoint_c, step.power_w)
        self.loops[step.heater] = PowerLoop(self.max_power_w[step.heater])
        output = self.outputs[step.heater]
        if not self.goals[step.heater].active:
            self.station.heater.enable(output, False)
            return
        power = step.power_w if step.power_w is not None else self.loops[step.heater].update(
            step.setpoint_c or 0.0, self._temperatures(fresh=True)[step.heater], 0.0)
        self._apply_power(step.heater, power)
        self.station.heater.enable(output, True)

    def _apply_power(self, heater: str, power_w: float) -> None:
        safety = self.station.config.safety
        volts = volts_for_power(min(power_w, self.max_power_w[heater]), self.heater_ohm[heater],
                                safety.heater_max_voltage_v)
        self.station.heater.set_output(self.outputs[heater], volts, safety.heater_max_current_a)

    def _control(self, dt_s: float, temperatures: dict[str, float]) -> None:
        """One control period for every heater that holds a temperature."""
        for heater, goal in self.goals.items():
            if goal.setpoint_c is not None:
                power = self.loops[heater].update(goal.setpoint_c, temperatures[heater], dt_s)
                self._apply_power(heater, power)

    def _wait_steady(self, step: WaitSteady) -> None:
        window: deque[tuple[float, float]] = deque()

        def steady(now: float, temperatures: dict[str, float]) -> bool:
            value = temperatures[step.heater]
            window.append((now, value))
            while len(window) > 1 and window[1][0] <= now - step.window_s:
                window.popleft()  # keep one reading at or before the window's start: it spans the window
            if self._bar is not None:
                self._bar.set_postfix_str(f"{step.heater} {value:.1f} C -> {step.setpoint_c:g} C")
            return self._steady(window, step) and abs(value - step.setpoint_c) <= step.tolerance_k

        self._regulate(step.heater, step.interval_s, step.timeout_s, step.log_interval_s, step.log_frequencies_hz,
                       steady, f"not steady at {step.setpoint_c:g} C")

    @staticmethod
    def _steady(window: deque[tuple[float, float]], step: WaitSteady) -> bool:
        """Slope of a straight-line fit over a full window below the threshold."""
        if len(window) < 3 or window[-1][0] - window[0][0] < step.window_s:
            return False
        n = len(window)
        mean_t = sum(t for t, _ in window) / n
        mean_v = sum(v for _, v in window) / n
        sxx = sum((t - mean_t) ** 2 for t, _ in window)
        slope = sum((t - mean_t) * (v - mean_v) for t, v in window) / sxx
        return abs(slope) * 60.0 <= step.slope_k_per_min

    def _cool_down(self, step: CoolDown) -> None:
        self._regulate(step.heater, step.interval_s, step.timeout_s, step.log_interval_s, step.log_frequencies_hz,
                       lambda now, temperatures: temperatures[step.heater] < step.below_c,
                       f"still at or above {step.below_c:g} C")

    def _regulate(self, heater: str, interval_s: float, timeout_s: float, log_interval_s: float,
                  log_frequencies_hz: tuple[float, ...], finished: Callable[[float, dict[str, float]], bool],
                  failure: str) -> None:
        """Every interval: read temperatures, control the heaters, log the bridge when due, until ``finished``."""
        start = last_log = self.clock.now()
        last_log -= log_interval_s
        while True:
            now = self.clock.now()
            temperatures = self._temperatures(fresh=True)
            self._control(interval_s, temperatures)
            done = finished(now, temperatures)
            if now - last_log >= log_interval_s:
                self._log_readings(log_frequencies_hz)
                last_log = now
            if done:
                log.info("%s: %.2f C after %.0f s", heater, temperatures[heater], now - start)
                return
            if now - start > timeout_s:
                raise EcdsLabError(f"{heater} {failure} after {timeout_s:g} s (now {temperatures[heater]:.1f} C)")
            self.clock.sleep(interval_s)

    def _log_readings(self, frequencies: tuple[float, ...]) -> None:
        for freq in frequencies:
            self._record(freq, LOGGED_POINT)

    # -- safe state ---------------------------------------------------------------------------
    def _make_safe(self, stop_slide: bool) -> None:
        """Heater off first (it can burn), then stop the slide; each attempted even if the other fails."""
        try:
            self.station.heater.all_off()
        except Exception as exc:  # the operator must hear of it, and the slide must still be stopped
            log.critical("could not switch the heater off: %s -- SWITCH IT OFF BY HAND", exc)
        if stop_slide:
            try:
                self.station.slide.stop()
            except Exception as exc:
                log.error("could not stop the slide: %s", exc)
