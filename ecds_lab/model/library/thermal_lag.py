"""thermal_lag: the winding's temperature lags the thermocouple on the former (first order).

The thermocouple reads the former, the inductance follows the winding; during ramps the
winding trails by a time constant tau_lag: dT_w/dt = (T_tc - T_w) / tau_lag, per recording.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import Effect, register
from ecds_lab.model.library.history import first_order_lag, first_order_lag_tau_derivative
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import Tangent, mapped, plus


@register
class ThermalLag(Effect):
    name = "thermal_lag"
    explains = "the winding lags the coil thermocouple during temperature changes"
    #: The winding lags its thermocouple by about w^2 / D over the former wall w between them (diffusivity D):
    #: from a bare winding (seconds) to 30 mm of plastic (D ~1e-7 m^2/s: ~9000 s) or ceramic (D ~5e-7: ~1800 s),
    #: small and large coils alike: 2 s to 3 h.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"lag_tau": (2.0, 10800.0)}
    reveal = "hold the coil hot for an hour and record the approach to steady state at a fixed distance"
    reveal_needs: ClassVar[dict[str, float]] = {"hold_s": 3000.0}
    alternative_starts = ({"lag_tau": 15.0}, {"lag_tau": 600.0}, {"lag_tau": 2400.0})

    def parameters(self) -> list[Parameter]:
        return [Parameter("lag_tau", 60.0, 1.0, 14400.0, "s", "time constant of the winding behind the thermocouple",
                          100.0)]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        rate = np.abs(data.coil_temperature_rate_k_per_s())
        return {} if rate.max(initial=0.0) > 1e-3 else {"lag_tau": "the coil temperature never changes"}

    def winding_temperature(self, t_c: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        out = np.array(t_c, dtype=float)
        for rows in data.segment_rows:
            out[rows] = first_order_lag(data.time_s[rows], out[rows], p["lag_tau"])
        return out

    def d_winding_temperature(self, t_c: np.ndarray, dt: Tangent, data: Measurements,
                              p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        """The lag is linear in the thermocouple's temperature, so an incoming tangent is lagged alike."""
        tau = p["lag_tau"]
        out = np.array(t_c, dtype=float)
        by_tau = np.zeros(len(out))
        for rows in data.segment_rows:
            out[rows] = first_order_lag(data.time_s[rows], t_c[rows], tau)
            by_tau[rows] = first_order_lag_tau_derivative(data.time_s[rows], t_c[rows], out[rows], tau)

        def lagged(values: np.ndarray) -> np.ndarray:
            result = np.array(values, dtype=float)
            for rows in data.segment_rows:
                result[rows] = first_order_lag(data.time_s[rows], values[rows], tau)
            return result

        return out, plus(mapped(dt, lagged), {"lag_tau": by_tau})
