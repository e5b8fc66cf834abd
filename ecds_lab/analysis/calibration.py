"""Calibration (paper Section 5): fit Eq. (5) on a room-temperature sweep, invert L to a position.

Position error e_pos = x_est - x_ref (mm, % of full scale FS = the calibrated span) and
temperature stability TS = e_pos / (FS dT) in ppm FS/K. A reading whose estimate the inversion
clamped to the search range, or whose error reaches FS, is out of range: it gives no error figure.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import Effect
from ecds_lab.model.sensor_model import SensorModel

#: Grid points of the first, tabulated stage of the position inversion, and Newton steps after it.
_INVERSION_GRID, _NEWTON_STEPS = 48, 3
#: Fraction of the range, from the near end, where the paper's few calibration points lie.
SENSITIVE_REGION = 0.3


@dataclass
class Calibration:
    """A fitted model for position estimates; FS is the span of the sweep it was calibrated on."""

    fit: FitResult
    positions_m: np.ndarray
    x_min_m: float
    x_max_m: float

    @property
    def fs_m(self) -> float:
        return self.x_max_m - self.x_min_m

    @property
    def n_points(self) -> int:
        return len(self.positions_m)

    def search_range_m(self) -> tuple[float, float]:
        """Where position estimates are searched: the calibrated span plus a quarter of FS each side."""
        margin = 0.25 * self.fs_m
        return max(self.x_min_m - margin, 1e-3), self.x_max_m + margin


@dataclass
class PositionErrors:
    """Estimated vs reference positions of readings with the target present."""

    x_ref_m: np.ndarray
    x_est_m: np.ndarray
    fs_m: float
    out_of_range: np.ndarray

    @property
    def error_m(self) -> np.ndarray:
        return self.x_est_m - self.x_ref_m

    @property
    def error_mm(self) -> np.ndarray:
        return self.error_m * 1e3

    @property
    def error_fs_percent(self) -> np.ndarray:
        return self.error_m / self.fs_m * 100

    @property
    def in_range(self) -> np.ndarray:
        """Readings the calibration speaks for: not clamped by the inversion, error below the full scale."""
        return ~self.out_of_range & (np.abs(self.error_m) < self.fs_m)

    def max_abs_mm(self) -> float:
        """Max |e_pos| over the readings in range (nan when none is): a clamped estimate is no error."""
        inside = self.in_range
        return float(np.max(np.abs(self.error_mm[inside]))) if inside.any() else float("nan")

    def rms_by_position_mm(self) -> tuple[np.ndarray, np.ndarray]:
        """Distinct reference positions (mm) and the RMS error at each (mm)."""
        positions, index = np.unique(np.round(self.x_ref_m, 7), return_inverse=True)
        sums = np.bincount(index, self.error_mm**2) / np.bincount(index)
        return positions * 1e3, np.sqrt(sums)


def room_temperature_rows(data: Measurements, tolerance_k: float = 3.0) -> np.ndarray:
    """Rows whose coil and target are both within ``tolerance_k`` of the room temperature.

    Room temperature is the data's 5th percentile of each thermocouple (air rows count for the coil).
    """
    coil_room = np.percentile(data.t_coil_c, 5)
    finite = np.isfinite(data.x_m)
    target_room = np.percentile(data.t_target_c[finite], 5) if finite.any() else np.inf
    coil_ok = np.abs(data.t_coil_c - coil_room) <= tolerance_k
    target_ok = ~finite | (np.abs(data.t_target_c - target_room) <= tolerance_k)
    return coil_ok & target_ok


def select_positions(x_m: np.ndarray, n_points: int | None = None, region: float = SENSITIVE_REGION) -> np.ndarray:
    """Calibration positions among the measured ones: all, or n spread over the near, sensitive part.

    Like the paper's n = 4 set, the few points lie where dL/dx is large: evenly over the first
    ``region`` of the range from the near end (the nearest measured position to each target).
    """
    available = np.unique(np.round(np.asarray(x_m, float)[np.isfinite(x_m)], 7))
    if n_points is None or n_points >= len(available):
        return available
    if n_points < 1:
        raise ValueError(f"n_points must be >= 1, got {n_points}")
    targets = np.linspace(available[0], available[0] + region * np.ptp(available), n_points)
    chosen: list[float] = []
    for t in targets:
        left = [x for x in available if x not in chosen]
        chosen.append(min(left, key=lambda x: abs(x - t)))
    return np.sort(np.array(chosen))


def calibrate(data: Measurements, sensor: SensorConfig | None = None, *, n_points: int | None = None,
              positions_m: Sequence[float] | None = None, fixed: Mapping[str, float] | None = None,
              effects: Sequence[str | Effect] = (), start: Mapping[str, float] | None = None) -> Calibration:
    """Fit the model (Eq. 5's p1..p4 and L0) on a sweep, with all points, n chosen ones or given ones.

    Coil-in-air rows in ``data`` are always used (they fix L_coil as in the paper); ``fixed``
    holds parameters at known values (e.g. alpha, beta from a compensation fit). ``start``: a solution
    already found on data these are part of (e.g. the full fit's values): the fit starts there and makes
    no global restarts of its own (that search was made for the solution given).
    """
    finite = np.isfinite(data.x_m)
    if not finite.any():
        raise ValueError("calibration needs readings with the target present")
    chosen = (np.unique(np.round(np.asarray(positions_m, float), 7)) if positions_m is not None
              else select_positions(data.x_m, n_points))
    rows = ~finite | np.isin(np.round(data.x_m, 7), chosen)
    if not (rows & finite).any():
        raise ValueError(f"none of the positions {chosen * 1e3} mm is in the data")
    model = SensorModel(sensor, effects)
    result = fit_model(model, data.select(rows), fixed=fixed, start=start, multistart=False if start else None)
    x = data.x_m[finite]
    return Calibration(result, chosen, float(x.min()), float(x.max()))


def estimate_positions(model: SensorModel, values: Mapping[str, float], data: Measurements,
                       x_range_m: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Invert measured Ls to distances (m), vectorised: tabulate the model over the range, then Newton.

    Returns the estimates (inf for coil-in-air rows) and a mask of readings outside the range
    (their estimate is clamped to its end).
    """
    lo, hi = x_range_m
    n = len(data)
    grid = np.linspace(lo, hi, _INVERSION_GRID)
    table = np.stack([model.predict(data, values, np.full(n, g)) for g in grid], axis=1)
    measured = data.ls_h
    increasing = table[:, -1] >= table[:, 0]
    signed = np.where(increasing[:, None], table, -table)
    target = np.where(increasing, measured, -measured)
    j = np.clip((signed < target[:, None]).sum(axis=1) - 1, 0, _INVERSION_GRID - 2)
    rows = np.arange(n)
    l_lo, l_hi = table[rows, j], table[rows, j + 1]
    fraction = np.clip((measured - l_lo) / np.where(l_hi != l_lo, l_hi - l_lo, 1.0), 0.0, 1.0)
    x = grid[j] + fraction * (grid[j + 1] - grid[j])
    for _ in range(_NEWTON_STEPS):
        here = model.predict(data, values, x)
        slope = model.sensitivity(data, values, x)
        x = np.clip(x - (here - measured) / np.where(slope != 0, slope, np.inf), lo, hi)
    out = (target < signed[:, 0]) | (target > signed[:, -1])
    air = ~np.isfinite(data.x_m)
    return np.where(air, np.inf, x), out & ~air


def position_errors(calibration: Calibration, data: Measurements,
                    values: Mapping[str, float] | None = None) -> PositionErrors:
    """Position errors of the readings with the target present (``values`` override the calibration's)."""
    rows = np.isfinite(data.x_m)
    part = data.select(rows)
    params = {**calibration.fit.values, **(values or {})}
    x_est, out = estimate_positions(calibration.fit.model, params, part, calibration.search_range_m())
    return PositionErrors(part.x_m, x_est, calibration.fs_m, out)


def noise_limited_error_m(model: SensorModel, values: Mapping[str, float], data: Measurements,
                          noise_relative: float) -> np.ndarray:
    """sigma_L / |dL/dx| (m): the position error bridge noise alone causes, per reading.

    The bridge's noise is ``noise_relative`` of |Z| on each component, so sigma(Ls) = noise |Z| / w.
    """
    z = model.impedance(data, values)
    omega = 2 * np.pi * data.freq_hz
    slope = model.sensitivity(data, values)
    return noise_relative * np.abs(z) / omega / np.abs(slope)


def temperature_stability_ppm_fs_per_k(error_m: np.ndarray, fs_m: float, delta_t_k: np.ndarray) -> np.ndarray:
    """TS = e_pos / (FS dT) in ppm FS/K (the paper's figure of merit)."""
    return np.asarray(error_m) / (fs_m * np.asarray(delta_t_k)) * 1e6
