"""The recorded (and derived) variables residuals are examined against: one table for analysis and plots."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ecds_lab.analysis.dataset import Measurements


@dataclass(frozen=True)
class Variable:
    """A variable of the data: how to get it (SI-ish units of the CSV), and how a plot labels it."""

    name: str
    unit: str
    label: str
    values: Callable[[Measurements], np.ndarray]
    categorical: bool = False
    display_factor: float = 1.0

    def display(self, data: Measurements) -> np.ndarray:
        """The values in the unit of ``label`` (e.g. time in hours)."""
        return self.values(data) * self.display_factor


VARIABLES: dict[str, Variable] = {v.name: v for v in (
    Variable("x_mm", "mm", "distance x (mm)", lambda d: np.where(np.isfinite(d.x_m), d.x_mm, np.nan)),
    Variable("freq_hz", "Hz", "frequency (Hz)", lambda d: d.freq_hz, categorical=True),
    Variable("t_coil_c", "C", "coil temperature (°C)", lambda d: d.t_coil_c),
    Variable("t_target_c", "C", "target temperature (°C)", lambda d: d.t_target_c),
    Variable("time_s", "s", "time in run (h)", lambda d: d.time_s, display_factor=1 / 3600.0),
    Variable("direction", "", "direction of approach",
             lambda d: np.where(np.isfinite(d.x_m), d.direction, np.nan).astype(float), categorical=True),
    Variable("coil_rate_k_per_min", "K/min", "coil temperature rate (K/min)",
             lambda d: d.coil_temperature_rate_k_per_s() * 60.0),
)}
