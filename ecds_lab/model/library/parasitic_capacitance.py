"""parasitic_capacitance: moisture in the former adds capacitance and loss; heating drives it out.

A porous former holds moisture m (1 at the start of a recording, when it has sat in the lab).
Heat dries it: dm/dt = -m r(T), r(T) = r100 * 2^((T - 100 C) / doubling), T the coil thermocouple.
The coil's parallel capacitance is C_p + dC m and its loss conductance 1/R_p + dG m (Table 2:
62.5 pF / 92 kOhm moist, 47.5 pF / 984 kOhm dry). Seen through L || C, the apparent L changes
like 1/(1 - w^2 L C): strongly at 15 kHz, hardly at 500 Hz, and with hysteresis on cooling.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ecds_lab.model.effects import Effect, Inputs, register
from ecds_lab.model.library.history import segment_rows
from ecds_lab.model.parameters import Parameter


@register
class ParasiticCapacitance(Effect):
    name = "parasitic_capacitance"
    explains = "moisture in the former changes the coil's parallel capacitance as heating dries it"
    alternative_starts = ({"drying_rate": 1e-4}, {"drying_rate": 1e-2})

    def parameters(self) -> list[Parameter]:
        return [
            Parameter("moist_dC", 1e-12, -1e-10, 1e-10, "F", "extra parallel capacitance of the moist former", 5e-12),
            Parameter("moist_dG", 1e-6, 0.0, 1e-4, "S", "extra loss conductance of the moist former", 3e-6),
            Parameter("drying_rate", 1.0 / 600, 1e-6, 1.0, "1/s", "drying rate of the former at 100 C", 1e-3),
            Parameter("drying_doubling", 12.0, 3.0, 60.0, "K", "temperature rise that doubles the drying rate", 5.0),
        ]

    def unidentifiable(self, data) -> dict[str, str]:  # noqa: ANN001
        span = float(np.ptp(data.t_coil_c)) if len(data) else 0.0
        if span < 10.0:
            return {n: f"coil temperature span {span:.1f} K < 10 K"
                    for n in ("moist_dC", "moist_dG", "drying_rate", "drying_doubling")}
        if float(data.freq_hz.max()) < 2000:
            return {"moist_dG": "low frequencies only: the loss hardly changes L"}
        return {}

    def moisture(self, data, p: Mapping[str, float]) -> np.ndarray:  # noqa: ANN001
        """m(t) per recording, integrated with the drying rate at the mean temperature of each interval."""
        key = (id(data), p["drying_rate"], p["drying_doubling"])
        if getattr(self, "_memo_key", None) == key:
            return self._memo
        out = np.ones(len(data))
        for rows in segment_rows(data):
            t, temp = data.time_s[rows], data.t_coil_c[rows]
            mid = 0.5 * (temp[1:] + temp[:-1])
            rate = p["drying_rate"] * np.exp2((mid - 100.0) / p["drying_doubling"])
            out[rows] = np.exp(-np.concatenate([[0.0], np.cumsum(rate * np.maximum(np.diff(t), 0.0))]))
        self._memo_key, self._memo = key, out
        return out

    def coil_capacitance(self, c_f: np.ndarray, inputs: Inputs, data, p: Mapping[str, float]) -> np.ndarray:  # noqa: ANN001
        return c_f + p["moist_dC"] * self.moisture(data, p)

    def parallel_conductance(self, g_s: np.ndarray, inputs: Inputs, data, p: Mapping[str, float]) -> np.ndarray:  # noqa: ANN001
        return g_s + p["moist_dG"] * self.moisture(data, p)
