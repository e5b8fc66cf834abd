"""target_tau_temperature: tau_T follows the target's conductivity, which falls as the target heats.

tau_T = L_T/R_T is proportional to the plate's conductivity (copper: ~0.39 %/K). Written as
ln tau = ln tau0 + a dT + b dT^2 (dT = target temperature rise), which covers both a linear fall
of conductivity and a linear rise of resistivity to within a fraction of a percent over 100 K.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import Effect, Inputs, register
from ecds_lab.model.parameters import Parameter


@register
class TargetTauTemperature(Effect):
    name = "target_tau_temperature"
    explains = "the target's eddy-current time constant changes with target temperature"

    def parameters(self) -> list[Parameter]:
        return [
            Parameter("tau_tempco", 0.0, -0.03, 0.03, "1/K", "d ln(tau_T) / d(target temperature)", 1e-3),
            Parameter("tau_tempco2", 0.0, -1e-4, 1e-4, "1/K^2", "curvature of ln(tau_T) in target temperature",
                      1e-6),
        ]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        span = float(np.ptp(data.t_target_c)) if len(data) else 0.0
        fixed: dict[str, str] = {}
        if span < 5.0:
            fixed.update(tau_tempco=f"target temperature span {span:.1f} K < 5 K", tau_tempco2="as tau_tempco")
        elif span < 30.0:
            fixed["tau_tempco2"] = f"target temperature span {span:.1f} K < 30 K"
        return fixed

    def target_tau(self, tau_s: np.ndarray, inputs: Inputs, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        d_t = inputs.t_target_c - self.sensor.reference_temperature_c
        return tau_s * np.exp(p["tau_tempco"] * d_t + p["tau_tempco2"] * d_t**2)
