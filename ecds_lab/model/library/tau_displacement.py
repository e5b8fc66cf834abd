"""tau_displacement: tau_T depends on the distance x.

The eddy-current pattern, and so the target's effective L_T/R_T, changes as the coil comes
closer (the paper's simulation: ~20 % at 30 mm). Written as ln tau = ln tau0 + c u + d u^2
with u = (x - 60 mm) / 40 mm, a smooth change over the 20-100 mm range.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ecds_lab.model.effects import Effect, Inputs, register
from ecds_lab.model.parameters import Parameter

REFERENCE_M, HALF_RANGE_M = 0.060, 0.040


@register
class TauDisplacement(Effect):
    name = "tau_displacement"
    explains = "the target's eddy-current time constant changes with distance"

    def parameters(self) -> list[Parameter]:
        return [
            Parameter("tau_x_slope", 0.0, -2.0, 2.0, "1", "change of ln(tau_T) from 60 mm to 100 mm", 0.05),
            Parameter("tau_x_curve", 0.0, -2.0, 2.0, "1", "curvature of ln(tau_T) over the range", 0.05),
        ]

    def unidentifiable(self, data) -> dict[str, str]:  # noqa: ANN001
        positions = len(np.unique(np.round(data.x_m[np.isfinite(data.x_m)], 6)))
        if positions < 6:
            return {"tau_x_slope": f"{positions} distinct positions", "tau_x_curve": f"{positions} distinct positions"}
        return {}

    def target_tau(self, tau_s: np.ndarray, inputs: Inputs, data, p: Mapping[str, float]) -> np.ndarray:  # noqa: ANN001
        u = np.where(np.isfinite(inputs.x_m), (inputs.x_m - REFERENCE_M) / HALF_RANGE_M, 0.0)
        return tau_s * np.exp(p["tau_x_slope"] * u + p["tau_x_curve"] * u**2)
