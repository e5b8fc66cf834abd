"""The readings a planned experiment will take: distance, frequency, direction, temperatures and time of each.

The plan (``runner.plan.build_plan``) says what is measured in which order; its lab-time estimate
(``runner.progress.estimate_plan``, from the station's ``thermal:`` block through ``runner/thermal_time.py``) says
how long each step takes. Temperatures follow the same first-order picture the estimate uses: a heated part
approaches its setpoint with the station's settling time constant and cools towards ambient with its cooling one;
readings logged while a heater waits are spaced as the estimate spaces them. The room temperature is the one the
campaign measured (its coldest readings), not a declared figure.
"""

from __future__ import annotations

import math

import numpy as np

from ecds_lab.config.station import StationConfig
from ecds_lab.data.measurements import Measurements
from ecds_lab.runner.plan import Plan
from ecds_lab.runner.progress import estimate_plan
from ecds_lab.runner.steps import CoolDown, Home, MeasurePoint, Park, WaitSteady


def room_temperature_c(data: Measurements) -> float:
    """The campaign's room temperature: the median of its coldest tenth of coil readings (never heated)."""
    coil = np.sort(data.t_coil_c[np.isfinite(data.t_coil_c)])
    return float(np.median(coil[: max(1, len(coil) // 10)])) if len(coil) else 22.0


def planned_readings(plan: Plan, station: StationConfig, room_c: float, campaign: Measurements, *,
                     coil_in_air: bool = False) -> Measurements:
    """One row per reading the plan will take, with the conditions it is taken at; ``ls_h`` NaN (to be predicted),
    ``rs_ohm`` the campaign's median at that frequency (only a start for a fit's de-embedding). ``coil_in_air``:
    the target is removed for the whole plan (a coil-heating run), every reading at x = inf."""
    thermal = station.thermal
    estimates = estimate_plan(plan)
    temperature = {"coil": room_c, "target": room_c}
    x_mm = math.inf
    clock = 0.0
    rows: list[tuple[float, float, float, float, float, int]] = []
    side = slide_approach(station)
    direction = side
    for step, estimate in zip(plan.steps, estimates, strict=True):
        if isinstance(step, Home):
            x_mm = float(station.slide.options.get("origin_mm", math.inf))
            clock += estimate.seconds
        elif isinstance(step, Park):
            direction = _approached(side, direction, x_mm, step.x_mm)
            x_mm = step.x_mm
            clock += estimate.seconds
        elif isinstance(step, MeasurePoint):
            if step.in_air:
                x_mm = math.inf
            elif step.x_mm is not None:
                direction = _approached(side, direction, x_mm, step.x_mm)
                x_mm = step.x_mm
            clock += estimate.seconds
            rows.append((clock, x_mm, step.freq_hz, temperature["coil"], temperature["target"], direction))
        elif isinstance(step, WaitSteady | CoolDown):
            part = getattr(thermal, step.heater)
            start_c = temperature[step.heater]
            if isinstance(step, WaitSteady):
                goal_c, tau = step.setpoint_c, part.settling_time_constant_s
            else:
                goal_c, tau = room_c, part.cooling_time_constant_s
            logged = int(estimate.rows)
            frequencies = step.log.frequencies_hz if step.log is not None else ()
            for i in range(logged // max(len(frequencies), 1)):
                t = estimate.seconds * i / max(logged // max(len(frequencies), 1), 1)
                reading_c = goal_c + (start_c - goal_c) * math.exp(-t / tau)
                temps = {**temperature, step.heater: reading_c}
                for f in frequencies:
                    rows.append((clock + t, x_mm, f, temps["coil"], temps["target"], direction))
            clock += estimate.seconds
            end_c = goal_c + (start_c - goal_c) * math.exp(-estimate.seconds / tau)
            temperature[step.heater] = end_c if isinstance(step, CoolDown) else step.setpoint_c
        else:
            clock += estimate.seconds
    table = np.array(rows, float).reshape(-1, 6)
    x_m = np.full(len(table), np.inf) if coil_in_air else table[:, 1] * 1e-3
    rs = np.array([_median_rs(campaign, f) for f in table[:, 2]])
    return Measurements(time_s=table[:, 0], x_m=x_m, freq_hz=table[:, 2], t_coil_c=table[:, 3],
                        t_target_c=table[:, 4], ls_h=np.full(len(table), np.nan), rs_ohm=rs,
                        segment=np.zeros(len(table), int), x_commanded_m=x_m,
                        direction=np.where(np.isfinite(x_m), table[:, 5], 0).astype(int),
                        slide_repeatability_m=np.full(len(table), (station.slide.repeatability_um or 0.0) * 1e-6),
                        source="planned")


def slide_approach(station: StationConfig) -> int:
    """+1 / -1 when the slide finishes every move from one side (the GRBL driver's ``approach`` option, positive by
    default), 0 when it approaches from the side it comes from (``direct``)."""
    return {"positive": 1, "negative": -1}.get(str(station.slide.options.get("approach", "positive")), 0)


def _approached(side: int, last: int, from_mm: float, to_mm: float) -> int:
    """The direction a move ends in: the slide's fixed side, else the sign of the move (the last one if none)."""
    if side:
        return side
    if not (math.isfinite(from_mm) and math.isfinite(to_mm)) or to_mm == from_mm:
        return last
    return 1 if to_mm > from_mm else -1


def _median_rs(campaign: Measurements, freq_hz: float) -> float:
    rows = campaign.freq_hz == freq_hz
    values = campaign.rs_ohm[rows] if rows.any() else campaign.rs_ohm
    return float(np.nanmedian(values)) if len(values) else 0.0
