"""Coil temperature compensation (paper Section 4): fit Eq. (4) on the coil in air, apply it.

The characterisation fits L0, alpha, beta (and C_p with two frequencies) to coil-in-air
readings over a heating run. Applied to a calibration, it turns the uncompensated position
error of a heated coil into the small remainder the paper reports (about 10 %).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ecds_lab.analysis.calibration import PositionErrors, calibrate, position_errors
from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.analysis.outliers import REPEATED, THRESHOLD
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.sensor_model import SensorModel


@dataclass
class TemperatureCompensation:
    """Eq. (4) coefficients from a coil-in-air characterisation, with their standard errors."""

    fit: FitResult
    reference_c: float

    @property
    def alpha_per_k(self) -> float:
        return self.fit.values["alpha"]

    @property
    def beta_per_k2(self) -> float:
        return self.fit.values["beta"]

    @property
    def l0_h(self) -> float:
        return self.fit.values["L0"]

    def factor(self, t_coil_c: np.ndarray) -> np.ndarray:
        """L_coil(t) / L0 = 1 + alpha dT + beta dT^2."""
        d = np.asarray(t_coil_c, float) - self.reference_c
        return 1 + self.alpha_per_k * d + self.beta_per_k2 * d**2

    def compensate(self, ls_h: np.ndarray, t_coil_c: np.ndarray) -> np.ndarray:
        """Readings referred to the reference temperature: L / (1 + alpha dT + beta dT^2) (L = L_coil (1 - k~))."""
        return np.asarray(ls_h, float) / self.factor(t_coil_c)


@dataclass
class CompensationResult:
    """Position errors of heated-coil readings with and without the temperature model."""

    uncompensated: PositionErrors
    compensated: PositionErrors
    compensation: TemperatureCompensation

    @property
    def ratio(self) -> float:
        """Max |e_pos| compensated / uncompensated (paper: about 0.1)."""
        return self.compensated.max_abs_mm() / self.uncompensated.max_abs_mm()


def fit_coil_temperature(data: Measurements, sensor: SensorConfig | None = None) -> TemperatureCompensation:
    """Fit Eq. (4) to the coil-in-air rows (x = inf) of a heating characterisation."""
    air = data.in_air
    if not air.any():
        raise ValueError("temperature characterisation needs coil-in-air readings (x_mm = inf)")
    model = SensorModel(sensor)
    return TemperatureCompensation(fit_model(model, data.select(air)), model.sensor.reference_temperature_c)


def compare_compensation(room_sweep: Measurements, heated: Measurements, compensation: TemperatureCompensation,
                         sensor: SensorConfig | None = None, n_points: int | None = None,
                         positions_m: Sequence[float] | None = None) -> CompensationResult:
    """Calibrate on a room-temperature sweep without and with Eq. (4), then estimate heated positions.

    Without: alpha = beta = 0, so L0 absorbs the room temperature and heating reads as distance.
    With: alpha, beta fixed at the characterisation's values and L0 refitted at room temperature.
    Both use the characterisation's C_p when it determined one (two frequencies).
    """
    shared = {} if compensation.fit.parameter("C_p").fixed else {"C_p": compensation.fit.values["C_p"]}
    plain = calibrate(room_sweep, sensor, n_points=n_points, positions_m=positions_m,
                      fixed={**shared, "alpha": 0.0, "beta": 0.0})
    corrected = calibrate(room_sweep, sensor, n_points=n_points, positions_m=positions_m,
                          fixed={**shared, "alpha": compensation.alpha_per_k, "beta": compensation.beta_per_k2})
    return CompensationResult(position_errors(plain, heated), position_errors(corrected, heated), compensation)


#: Successive readings whose coil temperature stays within this band (K) form one steady step.
STEP_BAND_K = 1.0
#: A steady step has at least this many readings (at one frequency).
STEP_MIN_READINGS = 3
#: Steps closer than this (K) are one set point approached in stages; the last one in time is kept.
STEP_MERGE_K = 3.0


def steady_coil_steps(air: Measurements, band_k: float = STEP_BAND_K,
                      min_readings: int = STEP_MIN_READINGS) -> list[np.ndarray]:
    """Row indices of the steady coil temperatures of a coil-in-air recording at one frequency.

    The first entry is room: the readings within ``band_k`` of the coolest one. The others are
    runs of at least ``min_readings`` successive readings whose temperature stays within
    ``band_k`` (a heater set point held while the bridge reads), coolest first; readings
    logged during a ramp change faster than that and belong to no step. Of steps within
    ``STEP_MERGE_K`` of each other only the last in time (the most settled) is kept.
    """
    if not len(air):
        return []
    t = air.t_coil_c
    steps = [np.flatnonzero(t <= t.min() + band_k)]
    start = 0
    for i in range(1, len(t) + 1):
        if i == len(t) or air.segment[i] != air.segment[start] or abs(t[i] - t[start]) > band_k:
            if i - start >= min_readings and t[start:i].mean() > t.min() + band_k:
                steps.append(np.arange(start, i))
            start = i
    runs = sorted(steps[1:], key=lambda rows: t[rows].mean())
    kept: list[np.ndarray] = []
    for rows in runs:
        if kept and t[rows].mean() - t[kept[-1]].mean() <= STEP_MERGE_K:
            kept[-1] = max(kept[-1], rows, key=lambda r: r[-1])
        else:
            kept.append(rows)
    return steps[:1] + kept


def step_level(values: np.ndarray) -> tuple[float, np.ndarray]:
    """The level of one steady step: the mean of its readings (in time order) without glitches, and the indices
    left out.

    A glitch is a single reading more than ``outliers.THRESHOLD`` robust sigmas (1.4826 MAD) from the
    step's median while neither neighbour in time deviates the same way by more than ``outliers.REPEATED``
    sigmas: the bridge erring once, not the coil. One such reading in a step of ten moves a plain mean by
    a tenth of its size (a 1.6 % glitch: 1600 ppm, more than the coil changes over 100 K at 500 Hz), and
    every figure built on the step with it. Readings that deviate together (a step still settling at its
    start) are the coil's and stay in the mean.
    """
    values = np.asarray(values, float)
    signed = values - np.median(values)
    sigma = 1.4826 * float(np.median(np.abs(signed)))
    if not sigma > 0:
        return float(np.mean(values)), np.zeros(0, int)
    z = signed / sigma
    suspect = np.abs(z) > THRESHOLD
    before = np.concatenate([[0.0], z[:-1]])
    after = np.concatenate([z[1:], [0.0]])
    repeated = (np.sign(before) == np.sign(z)) & (np.abs(before) > REPEATED)
    repeated |= (np.sign(after) == np.sign(z)) & (np.abs(after) > REPEATED)
    glitch = suspect & ~repeated
    return float(np.mean(values[~glitch])), np.flatnonzero(glitch)


def heated_coil_sweep(room_sweep: Measurements, air: Measurements, min_rise_k: float = 5.0) -> Measurements:
    """Heated-coil readings the paper's way (Section 5): a room sweep scaled by the air coil's change.

    L_ECDS(x, T) = L_coil(T) (1 - k~(x)): for every steady coil temperature T of the coil-in-air
    recording ``air`` (see ``steady_coil_steps``) and every frequency both hold, each room-sweep
    reading is scaled by L_air(T) / L_air(room) (each the step's level without glitches,
    ``step_level``) and takes the coil temperature T. Steps less than ``min_rise_k`` above room are
    skipped. Empty when the air recording has no steady step above room.
    """
    sweep = room_sweep.select(np.isfinite(room_sweep.x_m))
    parts: list[Measurements] = []
    for freq in np.intersect1d(sweep.frequencies_hz, air.frequencies_hz):
        at_f = air.select((air.freq_hz == freq) & air.in_air)
        steps = steady_coil_steps(at_f)
        if len(steps) < 2:
            continue
        room_l, room_t = step_level(at_f.ls_h[steps[0]])[0], float(np.mean(at_f.t_coil_c[steps[0]]))
        rows = sweep.select(sweep.freq_hz == freq)
        for step in steps[1:]:
            t_step = float(np.mean(at_f.t_coil_c[step]))
            if t_step - room_t < min_rise_k:
                continue
            ratio = step_level(at_f.ls_h[step])[0] / room_l
            parts.append(replace(rows, ls_h=rows.ls_h * ratio, t_coil_c=np.full(len(rows), t_step)))
    if not parts:
        return sweep.select(np.zeros(len(sweep), bool))
    return Measurements.concatenate(parts)


#: The method the paper used for Eq. (4) (Section 4.1-4.3), named wherever its coefficients are shown.
STEADY_EQ4_METHOD = "Eq. (4) fitted per frequency to the steady coil temperatures in air (the paper's procedure)"
#: Steady steps up to this many kelvin above room enter the paper's Eq. (4) fit (its 20-130 °C range).
STEADY_EQ4_SPAN_K = 110.0


@dataclass
class SteadyEq4:
    """Eq. (4) at one frequency the paper's way: L_air(T) = L0 (1 + alpha dT + beta dT^2), dT = T - reference,
    a quadratic through the mean L of each steady coil temperature in air (glitch readings left out of each
    mean and counted in ``glitches_excluded``, see ``step_level``)."""

    freq_hz: float
    reference_c: float
    t_coil_c: np.ndarray
    ls_h: np.ndarray
    l0_h: float
    alpha_per_k: float
    beta_per_k2: float
    method: str = STEADY_EQ4_METHOD
    glitches_excluded: int = 0

    def factor(self, t_coil_c: np.ndarray | float) -> np.ndarray:
        d = np.asarray(t_coil_c, float) - self.reference_c
        return 1 + self.alpha_per_k * d + self.beta_per_k2 * d**2

    @property
    def span_k(self) -> float:
        return float(np.ptp(self.t_coil_c))


def fit_steady_eq4(air: Measurements, freq_hz: float, reference_c: float) -> SteadyEq4 | None:
    """The paper's Eq. (4) at one frequency from the steady coil temperatures of coil-in-air readings.

    ``reference_c`` is the model's reference temperature, so alpha and beta are the model's own and
    can be held in a calibration. None with fewer than three steady temperatures (a quadratic needs them).
    """
    at_f = air.select((air.freq_hz == freq_hz) & air.in_air)
    steps = steady_coil_steps(at_f)
    t = np.array([at_f.t_coil_c[s].mean() for s in steps])
    levels = [step_level(at_f.ls_h[s]) for s in steps]
    ls = np.array([level for level, _ in levels])
    excluded = np.array([len(left_out) for _, left_out in levels], int)
    keep = t <= (t.min() + STEADY_EQ4_SPAN_K if len(t) else 0.0)
    t, ls = t[keep], ls[keep]
    if len(t) < 3:
        return None
    c2, c1, c0 = np.polyfit(t - reference_c, ls, 2)
    return SteadyEq4(float(freq_hz), reference_c, t, ls, float(c0), float(c1 / c0), float(c2 / c0),
                     glitches_excluded=int(excluded[keep].sum()))
