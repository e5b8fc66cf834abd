"""A study case measured: its design run on the faithful simulated lab with its truth switched on.

One continuous recording, as a lab would take it: the coil in air, a room-temperature sweep, the target
heated to each set point with a sweep at each, the coil heated in air through its set points (ramps and
steady states), a coil-heated sweep at the top set point, cooling in air. Every imperfection not in the
truth is off, so the truth is exactly what was switched on (plus the field solution's own physics).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig, sensor_from
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import BOX_HEATER_OUTPUT, TARGET_HEATER_OUTPUT, SimulatedLab
from ecds_lab.study.cases import SENSORS, Case, Design, merged

#: The faithful lab with every documented imperfection off (docs/simulated_lab.md); a truth switches its own on.
QUIET_LAB: dict[str, Any] = {
    "former": {"moisture": {"enabled": False}, "expansion": {"enabled": False}},
    "plate": {"conductivity": {"enabled": False}, "permeability": {"enabled": False},
              "gradient": {"enabled": False}, "bending": {"enabled": False}},
    "slide": {"backlash": {"enabled": False}, "lead_screw": {"enabled": False}, "repeatability": {"enabled": False}},
    "bridge": {"accuracy": {"enabled": False}, "glitches": {"enabled": False}},
}
#: Readings every ``HEATING_INTERVAL_S`` while a heater settles.
HEATING_INTERVAL_S = 120.0


def sensor_of(case: Case) -> SensorConfig:
    """The description of ``case``'s sensor, as its sensor YAML gives it to the lab and to the analysis."""
    return sensor_from(f"study sensor {case.sensor}", SENSORS[case.sensor].sensor)


def lab_config(case: Case) -> LabConfig:
    """The faithful lab of ``case``: its sensor, quiet, with the case's truth switched on."""
    return LabConfig(physics="field", seed=case.seed, sensor=sensor_of(case),
                     **merged(merged(QUIET_LAB, SENSORS[case.sensor].lab), case.blocks))


def positions_mm(design: Design) -> list[float]:
    """The design's distances: coarse over 20-100 mm, plus fine steps over 30-45 mm when asked."""
    coarse = np.linspace(20.0, 100.0, design.positions)
    fine = np.arange(30.0, 45.0 + 1e-9, 0.75) if design.fine_steps else np.array([])
    return sorted({round(float(x), 3) for x in np.concatenate([coarse, fine])})


def measure(case: Case) -> Measurements:
    """The case's campaign, read from its simulated lab."""
    design = case.design
    lab = SimulatedLab(lab_config(case))
    rec = campaign.Recorder(lab)
    freqs, where = design.frequencies_hz, positions_mm(design)

    def sweep() -> None:
        campaign.sweep(rec, where, freqs, design.directions, design.repeats)

    campaign.read_in_air(rec, freqs, 10)
    sweep()
    for setpoint in design.target_setpoints_c:
        campaign.set_heater(lab, TARGET_HEATER_OUTPUT, setpoint)
        lab.clock.sleep(campaign.settle_time_s(lab, TARGET_HEATER_OUTPUT))
        sweep()
    if design.target_setpoints_c:
        campaign.heat_and_record(rec, TARGET_HEATER_OUTPUT, None, freqs, 4 * HEATING_INTERVAL_S, in_air=True)
    for setpoint in design.coil_setpoints_c:
        campaign.heat_and_record(rec, BOX_HEATER_OUTPUT, setpoint, freqs, HEATING_INTERVAL_S, in_air=True)
    if design.coil_setpoints_c:
        sweep()
        campaign.heat_and_record(rec, BOX_HEATER_OUTPUT, None, freqs, HEATING_INTERVAL_S, in_air=True)
    data = rec.measurements(f"validation study case {case.number}")
    declared = float(case.blocks.get("slide", {}).get("repeatability", {}).get("sigma_um", 0.0)) * 1e-6
    return dataclasses.replace(data, slide_repeatability_m=np.full(len(data), declared))
