"""The readings a planned experiment will take: distance, frequency, direction, temperatures and time of each.

They are the rows its run will write and its measurements keep, by the runner's own rules (``planned_rows``): the
predicted Delta chi-square is counted on them. The plan (``runner.plan.build_plan``) says what is measured in
which order; its lab-time estimate (``runner.progress.estimate_plan``) says how long each step takes. A heater wait
is predicted from the campaign's recorded waits where it has one of that part (``planning.thermal_response``: how
long the run waits, the part's temperature along it, a log every log period from its start); otherwise from the
station's declared figures, as the estimate takes it (``runner/thermal_time.py``): a heated part approaches its
setpoint with the station's settling time constant and cools towards the room with its cooling one, and the
readings logged while it waits are spread over the estimated wait. The room temperature is the one the campaign
measured (its coldest readings), not a declared figure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ecds_lab.config.experiment import OVERHEAD_S, READING_S, reading_s
from ecds_lab.config.station import StationConfig
from ecds_lab.data.columns import LOGGED_POINT, PLANNED_POINT
from ecds_lab.data.measurements import Measurements
from ecds_lab.planning.planned_slide import PlannedSlide
from ecds_lab.planning.thermal_response import PlannedWait, ThermalResponse
from ecds_lab.runner.plan import Plan
from ecds_lab.runner.progress import estimate_plan, log_period_s, logged_rows
from ecds_lab.runner.rows import commanded_mm
from ecds_lab.runner.slide_position import SlidePosition
from ecds_lab.runner.steps import ConfigureBridge, CoolDown, Home, MeasurePoint, Park, WaitSteady
from ecds_lab.storage.reader import located


def room_temperature_c(data: Measurements) -> float:
    """The campaign's room temperature: the median of its coldest tenth of coil readings (never heated)."""
    coil = np.sort(data.t_coil_c[np.isfinite(data.t_coil_c)])
    return float(np.median(coil[: max(1, len(coil) // 10)])) if len(coil) else 22.0


@dataclass(frozen=True)
class PlannedRow:
    """One row the run of a plan will write: the step that takes it, planned point or logged while a heater waits
    (``data.columns`` kinds), when, where (commanded distance, mm; NaN unknown, +inf coil in air), at which
    frequency, temperatures and direction of approach."""

    step: int
    kind: int
    time_s: float
    x_commanded_mm: float
    freq_hz: float
    t_coil_c: float
    t_target_c: float
    direction: int


def planned_rows(plan: Plan, station: StationConfig, room_c: float,
                 response: ThermalResponse | None = None) -> list[PlannedRow]:
    """Every row the run of ``plan`` will write, in order, as its runner writes them.

    The rows are the runner's own: each planned point, and the readings a heater wait or cool-down logs (as many
    as the plan's estimate counts: the lab's response decides how many the run takes), at the commanded distance
    and direction of approach the runner's position bookkeeping (``runner.slide_position``) records over the
    station's slide (``PlannedSlide``), at x = inf when the coil is in air (``Plan.coil_in_air``,
    ``runner.rows.commanded_mm``). Temperatures and times follow the plan's estimate, or for a heater wait the
    campaign's recorded ``response`` where it has one of that part (module docstring)."""
    thermal = station.thermal
    temperature = {"coil": room_c, "target": room_c}
    position = SlidePosition(PlannedSlide(station))
    clock = 0.0
    reading = READING_S["slow"] + OVERHEAD_S  # as the estimate, until the plan configures the bridge
    rows: list[PlannedRow] = []

    def record(index: int, kind: int, at_s: float, freq_hz: float, in_air: bool, temps: dict[str, float]) -> None:
        rows.append(PlannedRow(index, kind, at_s, commanded_mm(position.x_mm, in_air), freq_hz, temps["coil"],
                               temps["target"], position.direction))

    for index, (step, estimate) in enumerate(zip(plan.steps, estimate_plan(plan), strict=True)):
        seconds = estimate.seconds
        if isinstance(step, ConfigureBridge):
            reading = reading_s(step.bridge)
        elif isinstance(step, Home):
            position.home()
        elif isinstance(step, Park):
            position.move_to(step.x_mm)
        elif isinstance(step, MeasurePoint):
            if step.x_mm is not None:
                position.move_to(step.x_mm)
            record(index, PLANNED_POINT, clock + estimate.seconds, step.freq_hz, step.in_air, temperature)
        elif isinstance(step, WaitSteady | CoolDown):
            frequencies = step.log.frequencies_hz if step.log is not None else ()
            start_c = temperature[step.heater]
            wait = _recorded_like(step, start_c, response)
            if wait is not None:  # the campaign's response: the runner's log period, from the wait's start
                seconds = wait.seconds
                logs = int(logged_rows(step, seconds, reading)) // max(len(frequencies), 1)
                period = log_period_s(step, reading)
                along = [(i * period, wait.temperature_c(i * period)) for i in range(logs)]
                end_c = wait.temperature_c(seconds)
            else:  # the station's declared first-order picture, the logs spread over the estimated wait
                part = getattr(thermal, step.heater)
                if isinstance(step, WaitSteady):
                    goal_c, tau = step.setpoint_c, part.settling_time_constant_s
                else:
                    goal_c, tau = room_c, part.cooling_time_constant_s
                logs = int(estimate.rows) // max(len(frequencies), 1)
                times = [seconds * i / max(logs, 1) for i in range(logs)]
                along = [(t, goal_c + (start_c - goal_c) * math.exp(-t / tau)) for t in times]
                end_c = goal_c + (start_c - goal_c) * math.exp(-seconds / tau)
            for t, heated_c in along:
                for f in frequencies:
                    record(index, LOGGED_POINT, clock + t, f, plan.coil_in_air, {**temperature, step.heater: heated_c})
            temperature[step.heater] = end_c if isinstance(step, CoolDown) else step.setpoint_c
        clock += seconds
    return rows


def planned_readings(plan: Plan, station: StationConfig, room_c: float, campaign: Measurements,
                     response: ThermalResponse | None = None) -> Measurements:
    """The readings the run of ``plan`` will record and its measurements will hold (``planned_rows`` with a known
    distance: readings logged after homing, before the slide's first move, have none and are left out, as
    ``storage.reader.located`` leaves them out of a run file's measurements); ``ls_h`` NaN (to be predicted),
    ``rs_ohm`` the campaign's median at that frequency (only a start for a fit's de-embedding)."""
    rows = planned_rows(plan, station, room_c, response)
    table = np.array([(r.time_s, r.x_commanded_mm, r.freq_hz, r.t_coil_c, r.t_target_c, r.direction)
                      for r in rows], float).reshape(-1, 6)
    table = table[located(table[:, 1])]
    x_m = table[:, 1] * 1e-3
    rs = np.array([_median_rs(campaign, f) for f in table[:, 2]])
    return Measurements(time_s=table[:, 0], x_m=x_m, freq_hz=table[:, 2], t_coil_c=table[:, 3],
                        t_target_c=table[:, 4], ls_h=np.full(len(table), np.nan), rs_ohm=rs,
                        segment=np.zeros(len(table), int), x_commanded_m=x_m, direction=table[:, 5].astype(int),
                        slide_repeatability_m=np.full(len(table), (station.slide.repeatability_um or 0.0) * 1e-6),
                        source="planned")


def slide_approach(station: StationConfig) -> int:
    """+1 / -1 when the slide finishes every move from one side (the GRBL driver's ``approach`` option, its default
    positive), 0 when it approaches from the side it comes from (``direct``)."""
    return {"positive": 1, "negative": -1}.get(PlannedSlide(station).approach, 0)


def _recorded_like(step: WaitSteady | CoolDown, start_c: float, response: ThermalResponse | None
                   ) -> PlannedWait | None:
    """The wait as the campaign's response predicts it, or None where it recorded no such wait of the part."""
    if response is None:
        return None
    if isinstance(step, WaitSteady):
        return response.heating(step.heater, start_c, step.setpoint_c, step.steady)
    return response.cooling(step.heater, start_c, step.below_c, step.timeout_s)


def _median_rs(campaign: Measurements, freq_hz: float) -> float:
    rows = campaign.freq_hz == freq_hz
    values = campaign.rs_ohm[rows] if rows.any() else campaign.rs_ohm
    return float(np.nanmedian(values)) if len(values) else 0.0
