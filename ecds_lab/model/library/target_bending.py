"""target_bending: the hot target bends, so the effective distance shifts with target temperature.

A plate heated from behind bows (its edges move toward or away from the coil); the coil sees
an effective distance x - b dT, b in m/K (positive: the plate comes closer as it heats).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ecds_lab.model.effects import Effect, register
from ecds_lab.model.parameters import Parameter


@register
class TargetBending(Effect):
    name = "target_bending"
    explains = "the hot target bends, shifting the effective distance"

    def parameters(self) -> list[Parameter]:
        return [Parameter("bending", 0.0, -1e-4, 1e-4, "m/K", "shift of the effective distance per kelvin of target",
                          2e-6)]

    def unidentifiable(self, data) -> dict[str, str]:  # noqa: ANN001
        finite = np.isfinite(data.x_m)
        span = float(np.ptp(data.t_target_c[finite])) if finite.any() else 0.0
        return {"bending": f"target temperature span {span:.1f} K < 5 K with the target present"} if span < 5 else {}

    def effective_distance(self, x_m: np.ndarray, data, p: Mapping[str, float]) -> np.ndarray:  # noqa: ANN001
        return x_m - p["bending"] * (data.t_target_c - self.sensor.reference_temperature_c)
