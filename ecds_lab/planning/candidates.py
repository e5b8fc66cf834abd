"""The experiments a station can do next: each a normal experiment configuration, validated against the station.

From the campaign (its frequencies, positions, directions, the temperatures it reached) and the station (the
bridge's frequencies, the slide's travel, the heaters' safety limits): the target hot at another frequency, the
other approach direction, finer positions, a hold of the coil hot, a repeat. Each is checked by the same checks a
run makes (``config.checks.check_experiment_fits_station``), so none leaves the station's travel or limits, and
its lab time is the plan's own estimate (``runner.progress``, from the station's ``thermal:`` block).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ecds_lab.analysis.diagnosis.advice import HOT_K
from ecds_lab.config.checks import check_experiment_fits_station, slide_travel_mm
from ecds_lab.config.experiment import EXPERIMENT_ADAPTER, BridgeConfig, ExperimentConfig
from ecds_lab.config.station import StationConfig
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.drivers.hm8118 import FREQUENCIES_HZ
from ecds_lab.errors import ConfigError
from ecds_lab.model.library.magnetic_depth import lowest_frequency_hz
from ecds_lab.planning.conditions import room_temperature_c, slide_approach
from ecds_lab.runner.plan import Plan, build_plan
from ecds_lab.runner.progress import PlanEstimate

#: Frequencies (Hz) the candidates try besides the campaign's: the bridge's nearest to these (a decade spread).
TRIED_HZ = (100.0, 500.0, 2000.0, 5000.0, 15000.0, 50000.0)
#: A setpoint stays this far below the station's over-temperature limit.
LIMIT_MARGIN_K = 10.0
#: Default hot setpoints when the campaign never heated the part (C), capped by the limit.
DEFAULT_HOT_C = {"target": 75.0, "coil": 60.0}
#: Holds of the hot coil (s) the candidates try.
HOLDS_S = (3600.0, 7200.0)
#: Finer positions: a band this long (mm) at this step (mm).
FINE_BAND_MM, FINE_STEP_MM = 15.0, 0.5
#: A direction counts as measured when at least this many distances were approached from it (the first move
#: from home approaches its first distance from above, whatever the sweep).
MIN_APPROACHED = 3
STEADY = {"slope_k_per_min": 0.1, "window_s": 300.0, "tolerance_k": 1.0, "interval_s": 10.0, "timeout_s": 21600.0}


@dataclass
class CandidateExperiment:
    """One experiment the station can do: its name, what it is in words, its configuration, plan and lab time."""

    name: str
    what: str
    experiment: ExperimentConfig
    plan: Plan
    hours: float

    def settings(self) -> dict[str, Any]:
        """The experiment as the YAML mapping ``ecds-lab run`` reads."""
        return self.experiment.model_dump(mode="json", exclude_defaults=True) | {"kind": self.experiment.kind}


@dataclass(frozen=True)
class CampaignReach:
    """What the campaign measured, as the candidates build on it."""

    frequencies_hz: tuple[float, ...]
    positions_mm: tuple[float, ...]
    directions: str  # "forward", "backward" or "both"
    room_c: float
    target_hot_c: float | None
    coil_hot_c: float | None

    @classmethod
    def of(cls, data: Measurements) -> CampaignReach:
        target = np.isfinite(data.x_m)
        positions = np.unique(np.round(data.x_commanded_m[target] * 1e3, 3))
        signs = {sign for sign in (1, -1) if len(np.unique(data.x_commanded_m[target & (data.direction == sign)]))
                 >= MIN_APPROACHED}
        directions = "both" if signs == {1, -1} else "backward" if signs == {-1} else "forward"
        room = room_temperature_c(data)
        hot_target = float(np.nanmax(data.t_target_c)) if len(data) else room
        hot_coil = float(np.nanmax(data.t_coil_c)) if len(data) else room
        return cls(tuple(float(f) for f in np.unique(data.freq_hz)), tuple(float(x) for x in positions), directions,
                   room, round(hot_target) if hot_target - room >= HOT_K else None,
                   round(hot_coil) if hot_coil - room >= HOT_K else None)


def _hot(station: StationConfig, part: str, reached: float | None) -> float:
    limit = station.safety.max_temperature_c.get(part, 140.0) - LIMIT_MARGIN_K
    return float(min(reached if reached is not None else DEFAULT_HOT_C[part], limit))


def _other_frequencies(reach: CampaignReach, sensor: SensorConfig | None) -> list[float]:
    """The bridge's frequencies nearest TRIED_HZ the campaign lacks, from the lowest the models describe the
    sensor's plate at (a steel plate: ``magnetic_depth.lowest_frequency_hz``, 13.4 kHz before the paper's coil)."""
    lowest = lowest_frequency_hz(sensor) if sensor is not None else 0.0
    near = {min(FREQUENCIES_HZ, key=lambda f: abs(np.log(f / wanted))) for wanted in TRIED_HZ}
    return sorted(float(f) for f in near if float(f) not in reach.frequencies_hz and f >= lowest)


def _sweep(reach: CampaignReach, frequencies: list[float], **changes: Any) -> dict[str, Any]:
    return {"positions_mm": list(reach.positions_mm), "frequencies_hz": frequencies, "direction": reach.directions,
            "settle_s": 2.0, **changes}


def candidate_settings(data: Measurements, station: StationConfig, sensor: SensorConfig | None = None,
                       bridge: BridgeConfig | None = None) -> list[tuple[str, str, dict[str, Any]]]:
    """(name, what, experiment mapping) of every candidate for this campaign of ``sensor`` on this station (not yet
    checked), each read with the campaign's ``bridge`` settings where they are known (``planning.recorded_bridge``:
    its noise is the campaign's), else the experiment's default."""
    return [(name, what, settings if bridge is None else {**settings, "bridge": bridge.model_dump(mode="json")})
            for name, what, settings in _candidate_settings(data, station, sensor)]


def _candidate_settings(data: Measurements, station: StationConfig, sensor: SensorConfig | None
                        ) -> list[tuple[str, str, dict[str, Any]]]:
    """``candidate_settings``' experiments, their bridge settings left to the default."""
    reach = CampaignReach.of(data)
    freqs = list(reach.frequencies_hz)
    out: list[tuple[str, str, dict[str, Any]]] = []
    low, high = slide_travel_mm(station)
    if reach.positions_mm:
        target_hot = _hot(station, "target", reach.target_hot_c)
        warm = round(reach.room_c + 2.0, 1)
        for f in _other_frequencies(reach, sensor):
            out.append((f"target_hot_{f:g}hz", f"the target at {warm:g} C and {target_hot:g} C, a sweep at each, "
                        f"at {f:g} Hz", {"kind": "target_heating", "name": f"target at {target_hot:g} C, {f:g} Hz",
                                        "heating": {"setpoints_c": [warm, target_hot], "steady": STEADY,
                                                    "log_interval_s": 120.0},
                                        "sweep": _sweep(reach, [f])}))
        if reach.directions != "both" and slide_approach(station) == 0:  # the slide can approach from both sides
            out.append(("both_directions", "a sweep approaching from both directions at room temperature",
                        {"kind": "displacement_sweep", "name": "sweep in both directions",
                         "sweep": _sweep(reach, freqs, direction="both")}))
            if reach.target_hot_c is not None:
                out.append(("both_directions_target_hot", f"the target at {target_hot:g} C, a sweep approaching "
                            "from both directions", {"kind": "target_heating", "name": "hot sweep, both directions",
                                                     "heating": {"setpoints_c": [target_hot], "steady": STEADY,
                                                                 "log_interval_s": 120.0},
                                                     "sweep": _sweep(reach, freqs, direction="both")}))
        start = max(min(reach.positions_mm), low)
        fine = [round(float(x), 3) for x in np.arange(start, min(start + FINE_BAND_MM, high) + 1e-9, FINE_STEP_MM)]
        out.append(("fine_steps", f"a sweep in {FINE_STEP_MM:g} mm steps over {fine[0]:g}-{fine[-1]:g} mm",
                    {"kind": "displacement_sweep", "name": "fine steps",
                     "sweep": _sweep(reach, [max(freqs)], positions_mm=fine)}))
        if reach.directions != "both" and slide_approach(station) == 0:  # the near range from both sides
            out.append(("fine_steps_both_directions", f"a sweep in {FINE_STEP_MM:g} mm steps over "
                        f"{fine[0]:g}-{fine[-1]:g} mm approaching from both directions",
                        {"kind": "displacement_sweep", "name": "fine steps, both directions",
                         "sweep": _sweep(reach, [max(freqs)], positions_mm=fine, direction="both")}))
        out.append(("repeat", "the campaign's sweep once more at room temperature",
                    {"kind": "displacement_sweep", "name": "repeat sweep", "sweep": _sweep(reach, freqs)}))
    coil_hot = _hot(station, "coil", reach.coil_hot_c)
    middle = round((reach.room_c + coil_hot) / 2.0, 1)
    cool_c = round(reach.room_c + 10.0, 1)
    out.append(("coil_ramps", f"the coil in air stepped to {middle:g} C and {coil_hot:g} C and cooled to "
                f"{cool_c:g} C, logged every minute through the ramps",
                {"kind": "coil_heating", "name": f"coil ramps to {coil_hot:g} C", "park_mm": high,
                 "frequencies_hz": freqs, "readings": 3,
                 "heating": {"setpoints_c": [middle, coil_hot], "steady": STEADY, "log_interval_s": 60.0,
                             "cool_down_to_c": cool_c}}))
    for hold in HOLDS_S:
        out.append((f"coil_hold_{hold / 3600:g}h", f"the coil in air held at {coil_hot:g} C for {hold / 3600:g} h, "
                    "logged every 5 min", {"kind": "coil_heating", "name": f"coil hold at {coil_hot:g} C",
                                           "park_mm": high, "frequencies_hz": freqs, "readings": 3,
                                           "heating": {"setpoints_c": [coil_hot],
                                                       "steady": {**STEADY, "window_s": hold},
                                                       "log_interval_s": 300.0, "cool_down_to_c": None}}))
    if reach.positions_mm:  # the coil hot at the target needs the campaign's own sweep at room temperature beside it
        out.append(("coil_hot_sweep", f"the coil at {coil_hot:g} C with the target in place, a sweep there",
                    {"kind": "coil_heating", "name": f"coil at {coil_hot:g} C, sweep", "frequencies_hz": freqs,
                     "coil_in_air": False,
                     "heating": {"setpoints_c": [coil_hot], "steady": STEADY, "log_interval_s": 120.0},
                     "sweep": _sweep(reach, freqs)}))
    return out


def station_candidates(data: Measurements, station: StationConfig, max_hours: float | None = None,
                       done: Sequence[dict[str, Any]] = (), sensor: SensorConfig | None = None,
                       bridge: BridgeConfig | None = None) -> tuple[list[CandidateExperiment], dict[str, str]]:
    """The candidates that validate, fit the station and (with ``max_hours``) fit the time, and are not among the
    experiments ``done`` already (their settings); and those refused (name -> why). ``sensor`` and ``bridge`` (its
    settings): the campaign's."""
    kept, refused = [], {}
    for name, what, settings in candidate_settings(data, station, sensor, bridge):
        try:
            candidate = _checked(name, what, settings, station)
        except (ValueError, ConfigError) as error:
            refused[name] = str(error).splitlines()[0]
            continue
        if candidate.settings() in done:
            refused[name] = "already measured in an earlier round"
            continue
        if max_hours is not None and candidate.hours > max_hours:
            refused[name] = f"{candidate.hours:.2f} h of lab time, more than the {max_hours:g} h allowed"
            continue
        kept.append(candidate)
    return kept, refused


def repeated(candidate: CandidateExperiment, times: int, station: StationConfig) -> CandidateExperiment | None:
    """``candidate`` with its sweep passed ``times`` as often (each pass a new visit of every position, so its
    positioning error is drawn anew): more readings where one pass separates the rivals but not by enough. None for
    a candidate without a sweep (a hold in air) or one the station refuses so long."""
    settings = candidate.settings()
    sweep = settings.get("sweep")
    if sweep is None:
        return None
    passes = {**sweep, "repeats": int(sweep.get("repeats", 1)) * times}
    try:
        return _checked(f"{candidate.name}_x{times}", f"{candidate.what}, passed {times} times",
                        {**settings, "sweep": passes}, station)
    except (ValueError, ConfigError):
        return None


def _checked(name: str, what: str, settings: dict[str, Any], station: StationConfig) -> CandidateExperiment:
    """The candidate ``settings`` validated as an experiment and checked against the station as ``run`` checks it
    (raises ValueError or ConfigError saying why not), with its plan and lab time."""
    experiment = EXPERIMENT_ADAPTER.validate_python(settings)
    check_experiment_fits_station(experiment, station, name)
    plan = build_plan(experiment, station.thermal, station.regulation)
    return CandidateExperiment(name, what, experiment, plan, PlanEstimate(plan).total_s() / 3600.0)
