"""Checks that need both files: does this experiment fit this station's slide, heaters and limits?"""

from __future__ import annotations

import math

from ecds_lab.config.experiment import CoilHeating, DisplacementSweep, Spectroscopy, SweepConfig, TargetHeating
from ecds_lab.config.station import StationConfig
from ecds_lab.errors import ConfigError
from ecds_lab.instruments.kinds import kind

Experiment = DisplacementSweep | CoilHeating | TargetHeating | Spectroscopy


def slide_travel_mm(station: StationConfig, station_source: str = "station") -> tuple[float, float]:
    """The slide's soft travel limits: the station's options, else the travel its driver declares.

    A slide driver that declares no ``default_travel_mm`` has no soft limits to check against. Limits that
    are not finite numbers, or a minimum not below the maximum, raise ConfigError naming the station file
    and the option (not the experiment, whose positions are then not at fault).
    """
    declared = getattr(kind(station.slide.driver).driver_class(), "default_travel_mm", (0.0, math.inf))
    options = station.slide.options
    limits = {}
    for i, name in enumerate(("min_mm", "max_mm")):
        value = options.get(name, declared[i])
        if name in options and (isinstance(value, bool) or not isinstance(value, (int, float))
                                or not math.isfinite(value)):
            raise ConfigError(f"{station_source}: field 'slide.options.{name}': {value!r} is not a number; "
                              f"allowed: a finite number of mm")
        limits[name] = float(value)
    if limits["min_mm"] >= limits["max_mm"]:
        raise ConfigError(f"{station_source}: field 'slide.options.min_mm': {limits['min_mm']:g} mm is not below "
                          f"max_mm {limits['max_mm']:g} mm; allowed: min_mm < max_mm")
    return limits["min_mm"], limits["max_mm"]


def check_experiment_fits_station(experiment: Experiment, station: StationConfig, source: str,
                                  station_source: str = "station") -> None:
    """Raise ConfigError (file, field, allowed values) before any instrument is opened."""
    problems: list[str] = []
    low, high = slide_travel_mm(station, station_source)

    def positions(field: str, values: list[float]) -> None:
        for i, x in enumerate(values):
            if not low <= x <= high:
                problems.append(f"{source}: field '{field}[{i}]': {x:g} mm is beyond the slide's travel "
                                f"(allowed {low:g}..{high:g} mm)")

    sweeps: list[tuple[str, SweepConfig]] = []
    if isinstance(experiment, (DisplacementSweep, TargetHeating)):
        sweeps.append(("sweep", experiment.sweep))
    if isinstance(experiment, CoilHeating) and experiment.sweep is not None:
        sweeps.append(("sweep", experiment.sweep))
    for name, sweep in sweeps:
        field = f"{name}.positions_mm" if sweep.positions_mm is not None else f"{name}.start_mm/stop_mm"
        positions(field, sweep.positions())
    if isinstance(experiment, (CoilHeating, Spectroscopy)) and experiment.park_mm is not None:
        positions("park_mm", [experiment.park_mm])

    limits = station.safety.max_temperature_c
    heating = []
    if isinstance(experiment, CoilHeating):
        heating.append(("heating.setpoints_c", "coil", experiment.heating.setpoints_c, experiment.heating.powers_w))
    if isinstance(experiment, TargetHeating):
        heating.append(("heating.setpoints_c", "target", experiment.heating.setpoints_c, experiment.heating.powers_w))
    if isinstance(experiment, Spectroscopy) and experiment.coil_temperatures_c:
        heating.append(("coil_temperatures_c", "coil", experiment.coil_temperatures_c, None))
    safety = station.safety
    for field, channel, setpoints, powers in heating:
        limit = limits.get(channel)
        for i, setpoint in enumerate(setpoints):
            if limit is not None and setpoint >= limit:
                problems.append(f"{source}: field '{field}[{i}]': {setpoint:g} C is at or above the station's "
                                f"{channel} limit (allowed below {limit:g} C, safety.max_temperature_c)")
        ohm = station.heaters.target_heater_ohm if channel == "target" else station.heaters.coil_heater_ohm
        volts, amps = safety.heater_max_voltage_v, safety.heater_max_current_a
        max_power = min(volts ** 2 / ohm, volts * amps)
        for i, power in enumerate(powers or []):
            if not 0 <= power <= max_power:
                problems.append(f"{source}: field 'heating.powers_w[{i}]': {power:g} W exceeds the heater limit "
                                f"(allowed 0..{max_power:.1f} W with {safety.heater_max_voltage_v:g} V, "
                                f"{safety.heater_max_current_a:g} A, {ohm:g} Ohm)")
    if problems:
        raise ConfigError("\n".join(problems))
