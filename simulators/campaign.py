"""Measurement campaigns driven directly on a ``SimulatedLab``, returned as ``Measurements``.

The lab's state is driven as the real experiments would (slide moves, heater supply
outputs, waiting on the shared clock) and every reading is what the bridge and the
thermocouples would report. No instrument protocol is involved, so a campaign of a few
thousand readings takes well under a second; issue 6 reuses these to hide effects.
Heating is open loop: the supply is set to the power whose steady state is the set
point, from the lab's thermal constants.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import BOX_HEATER_OUTPUT, TARGET_HEATER_OUTPUT, SimulatedLab

#: Time of one slow bridge reading (s) and of changing the test frequency.
READING_TIME_S = 0.6
FREQUENCY_SWITCH_S = 0.5
#: Slide feed rate (mm/min) and settling time after a move (s).
FEED_MM_PER_MIN = 600.0
SETTLE_S = 2.0
#: Overshoot (mm) used to approach the first position of a recording from the sweep's direction.
BACKLASH_TAKE_UP_MM = 1.0
#: Paper: 20-100 mm in 31 positions, 500 Hz and 15 kHz.
PAPER_POSITIONS_MM = tuple(np.linspace(20.0, 100.0, 31).tolist())
PAPER_FREQUENCIES_HZ = (500.0, 15000.0)


@dataclass
class Recorder:
    """Readings as they are taken: one row per bridge reading."""

    lab: SimulatedLab
    rows: list[tuple[float, ...]] = field(default_factory=list)

    def read(self, frequencies_hz: Iterable[float], repeats: int = 1) -> None:
        """``repeats`` slow readings at each frequency, with both thermocouples, at the lab's state now."""
        lab, noise = self.lab, self.lab.config.noise.thermocouple_k
        for frequency in frequencies_hz:
            lab.clock.advance(FREQUENCY_SWITCH_S)
            for _ in range(repeats):
                lab.clock.advance(READING_TIME_S)
                z = lab.measured_impedance(frequency, "slow", 1.5)
                self.rows.append((lab.clock.now(), commanded_distance_m(lab), float(frequency),
                                  lab.noisy(lab.temperature_c("coil"), noise),
                                  lab.noisy(lab.temperature_c("target"), noise),
                                  z.imag / (2 * math.pi * frequency), z.real))

    def measurements(self, source: str = "simulated campaign") -> Measurements:
        time_s, x_m, freq_hz, t_coil_c, t_target_c, ls_h, rs_ohm = np.array(self.rows, float).reshape(-1, 7).T
        return Measurements(time_s, x_m, freq_hz, t_coil_c, t_target_c, ls_h, rs_ohm, source=source)


def commanded_distance_m(lab: SimulatedLab) -> float:
    """The distance the experimenter believes in: slide origin plus motor position; inf without target."""
    if not lab.config.target_present:
        return math.inf
    return (lab.config.slide_origin_mm + lab.slide.motor_mm) * 1e-3


def move_to(lab: SimulatedLab, distance_mm: float) -> None:
    """Drive the slide to a coil-target distance and let it settle."""
    duration = lab.start_move(distance_mm - lab.config.slide_origin_mm, FEED_MM_PER_MIN)
    lab.clock.sleep(duration + SETTLE_S)


def take_up_backlash(lab: SimulatedLab, distance_mm: float, direction: int) -> None:
    """Arrive at the first position of a recording moving in ``direction`` (+1: increasing distance).

    A recording's direction of approach is inferred from its own positions (docs/data-contract.md), so its
    first reading must be approached the way its first recorded move goes.
    """
    move_to(lab, distance_mm - direction * BACKLASH_TAKE_UP_MM)
    move_to(lab, distance_mm)


def set_heater(lab: SimulatedLab, output: int, setpoint_c: float | None) -> None:
    """Set a heater's supply to the power whose steady state is ``setpoint_c`` (None or ambient: off)."""
    th = lab.config.thermal
    k_per_w = th.target_k_per_w if output == TARGET_HEATER_OUTPUT else th.box_k_per_w
    power = 0.0 if setpoint_c is None else max(setpoint_c - th.ambient_c, 0.0) / k_per_w
    if power <= 0:
        lab.set_supply(output, on=False, voltage_v=0.0)
        return
    volts = math.sqrt(power * lab.heater_load_ohm(output))
    lab.set_supply(output, voltage_v=volts, current_limit_a=1.5 * volts / lab.heater_load_ohm(output), on=True)


def settle_time_s(lab: SimulatedLab, output: int, time_constants: float = 6.0) -> float:
    """Time for a heater step to settle: a few of the slowest time constants on that path."""
    th = lab.config.thermal
    tau = th.target_tau_s if output == TARGET_HEATER_OUTPUT else th.box_tau_s + th.former_tau_s
    return time_constants * tau


def sweep(rec: Recorder, positions_mm: Sequence[float], frequencies_hz: Iterable[float],
          directions: Sequence[str] = ("forward", "backward"), repeats: int = 1) -> None:
    """Record a displacement sweep into ``rec``: each direction in turn, every position and frequency."""
    frequencies = list(frequencies_hz)
    for direction in directions:
        if direction not in ("forward", "backward"):
            raise ValueError(f"direction must be 'forward' or 'backward', got {direction!r}")
        ordered = sorted(positions_mm, reverse=direction == "backward")
        if not np.isfinite([row[1] for row in rec.rows]).any():
            take_up_backlash(rec.lab, ordered[0], 1 if direction == "forward" else -1)
        for x in ordered:
            move_to(rec.lab, x)
            rec.read(frequencies, repeats)


def read_in_air(rec: Recorder, frequencies_hz: Iterable[float], repeats: int = 1) -> None:
    """Readings of the coil in air (target removed), then the target is put back as it was."""
    lab = rec.lab
    present = lab.config.target_present
    lab.config.target_present = False
    try:
        rec.read(frequencies_hz, repeats)
    finally:
        lab.config.target_present = present


def heat_and_record(rec: Recorder, output: int, setpoint_c: float | None, frequencies_hz: Sequence[float],
                    interval_s: float = 120.0, in_air: bool = False) -> None:
    """Step a heater and take readings every ``interval_s`` until it has settled (ramp and steady state)."""
    set_heater(rec.lab, output, setpoint_c)
    end = rec.lab.clock.now() + settle_time_s(rec.lab, output)
    while rec.lab.clock.now() < end:
        rec.lab.clock.sleep(interval_s)
        if in_air:
            read_in_air(rec, frequencies_hz)
        else:
            rec.read(frequencies_hz)


def displacement_sweep(lab: SimulatedLab, positions_mm: Sequence[float] = PAPER_POSITIONS_MM,
                       frequencies_hz: Sequence[float] = PAPER_FREQUENCIES_HZ,
                       directions: Sequence[str] = ("forward", "backward"), repeats: int = 1,
                       air_repeats: int = 0) -> Measurements:
    """A sweep at the lab's current temperatures, optionally with coil-in-air readings first."""
    rec = Recorder(lab)
    if air_repeats:
        read_in_air(rec, frequencies_hz, air_repeats)
    sweep(rec, positions_mm, frequencies_hz, directions, repeats)
    return rec.measurements("displacement sweep")


def coil_heating(lab: SimulatedLab, setpoints_c: Sequence[float] = (40, 60, 80, 100, 120),
                 frequencies_hz: Sequence[float] = PAPER_FREQUENCIES_HZ, interval_s: float = 120.0,
                 cool_down: bool = True) -> Measurements:
    """Coil in air in the thermal box: readings during each ramp and at each steady state, then cooling."""
    rec = Recorder(lab)
    read_in_air(rec, frequencies_hz, 3)
    for setpoint in setpoints_c:
        heat_and_record(rec, BOX_HEATER_OUTPUT, setpoint, frequencies_hz, interval_s, in_air=True)
    if cool_down:
        heat_and_record(rec, BOX_HEATER_OUTPUT, None, frequencies_hz, interval_s, in_air=True)
    return rec.measurements("coil heating")


def heated_sweeps(lab: SimulatedLab, output: int, setpoints_c: Sequence[float],
                  positions_mm: Sequence[float] = PAPER_POSITIONS_MM,
                  frequencies_hz: Sequence[float] = PAPER_FREQUENCIES_HZ,
                  directions: Sequence[str] = ("forward", "backward"), repeats: int = 1,
                  label: str = "heated sweeps") -> Measurements:
    """A heater output brought to each set point (steady state), a sweep at each."""
    rec = Recorder(lab)
    for setpoint in setpoints_c:
        set_heater(lab, output, setpoint)
        lab.clock.sleep(settle_time_s(lab, output))
        sweep(rec, positions_mm, frequencies_hz, directions, repeats)
    return rec.measurements(label)


def target_heating(lab: SimulatedLab, setpoints_c: Sequence[float] = (75, 130), **sweep_options: Any) -> Measurements:
    """Target heated to each set point (steady state), a sweep at each; heater off at the end."""
    data = heated_sweeps(lab, TARGET_HEATER_OUTPUT, setpoints_c, label="target heating", **sweep_options)
    set_heater(lab, TARGET_HEATER_OUTPUT, None)
    return data


def coil_heated_sweeps(lab: SimulatedLab, setpoints_c: Sequence[float] = (120,), **sweep_options: Any) -> Measurements:
    """Coil heated to each set point (steady state) with the target present, a sweep at each."""
    return heated_sweeps(lab, BOX_HEATER_OUTPUT, setpoints_c, label="coil-heated sweeps", **sweep_options)


def spectroscopy(lab: SimulatedLab, frequencies_hz: Sequence[float], repeats: int = 1) -> Measurements:
    """Readings over a list of frequencies at the lab's current state (impedance spectroscopy)."""
    rec = Recorder(lab)
    rec.read(frequencies_hz, repeats)
    return rec.measurements("spectroscopy")


def paper_campaign(config: LabConfig | None = None, seed: int | None = 0, *,
                   positions_mm: Sequence[float] = PAPER_POSITIONS_MM,
                   frequencies_hz: Sequence[float] = PAPER_FREQUENCIES_HZ, repeats: int = 1,
                   target_setpoints_c: Sequence[float] = (75, 130),
                   coil_setpoints_c: Sequence[float] = (40, 60, 80, 100, 120),
                   interval_s: float = 120.0) -> Measurements:
    """The paper's experiments in one continuous recording (one segment) on a fresh simulated lab.

    Coil in air at room temperature; room-temperature sweep both directions; target heating
    sweeps; coil heating in air (ramps and steady states); a coil-heated sweep at the top set
    point; cooling in air. About 1,000 readings with the defaults.
    """
    config = (config or LabConfig()).model_copy(update={"seed": seed})
    lab = SimulatedLab(config)
    rec = Recorder(lab)
    read_in_air(rec, frequencies_hz, 10)
    sweep(rec, positions_mm, frequencies_hz, repeats=repeats)
    for setpoint in target_setpoints_c:
        set_heater(lab, TARGET_HEATER_OUTPUT, setpoint)
        lab.clock.sleep(settle_time_s(lab, TARGET_HEATER_OUTPUT))
        sweep(rec, positions_mm, frequencies_hz, repeats=repeats)
    heat_and_record(rec, TARGET_HEATER_OUTPUT, None, frequencies_hz, 4 * interval_s, in_air=True)
    for setpoint in coil_setpoints_c:
        heat_and_record(rec, BOX_HEATER_OUTPUT, setpoint, frequencies_hz, interval_s, in_air=True)
    sweep(rec, positions_mm, frequencies_hz, repeats=repeats)
    heat_and_record(rec, BOX_HEATER_OUTPUT, None, frequencies_hz, interval_s, in_air=True)
    return rec.measurements("paper campaign (simulated)")
