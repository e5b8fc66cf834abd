"""Coil temperature compensation (paper Section 4): fit Eq. (4) on the coil in air, apply it.

The characterisation fits L0, alpha, beta (and C_p with two frequencies) to coil-in-air
readings over a heating run. Applied to a calibration, it turns the uncompensated position
error of a heated coil into the small remainder the paper reports (about 10 %).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ecds_lab.analysis.calibration import PositionErrors, calibrate, position_errors
from ecds_lab.analysis.dataset import Measurements
from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.model.sensor import SensorConfig
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
