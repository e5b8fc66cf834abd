"""former_expansion: the former's thermal expansion scales the winding, so the coupling k(x) changes
with coil temperature, not only L_coil (Eq. 4 assumes it does not).

Scaling every length of the coil (radii, height) by s = 1 + a dT scales its self-inductance and
the mutual inductance to its mirror image alike, at the mirror distance scaled too (image method,
``model.coupling``): k^2(x; s) = M_image(x / s) / L = k^2(x / s). The coil in a hot former thus
couples to the target as the cold coil would at the distance x / s; with Eq. (5) the calibrated
distance (x - p1) becomes (x - p1) / s. The change of L_coil itself (L grows with s) is carried
by Eq. (4)'s alpha, which this effect leaves free; the coupling part identifies a. Parameter: the
former's linear expansion coefficient a (gypsum 25e-6 /K, fired clay 7.5e-6 /K, PHYSICS.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import Effect, register
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import Tangent, chained

#: Coil temperature span (K) with the target present, and distinct positions, needed to see a.
MIN_SPAN_K = 10.0
MIN_POSITIONS = 3


@register
class FormerExpansion(Effect):
    name = "former_expansion"
    explains = "the former's thermal expansion scales the winding, so the coupling changes with coil temperature"
    #: Ceramics ~5-10e-6 /K, gypsum 25e-6 /K, plastics up to ~100e-6 /K; a former does not shrink when heated.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"former_alpha": (-2e-6, 150e-6)}
    reveal = ("sweep the distance with the coil hot and cold (coil-heated sweeps): the expansion changes L "
              "most near the target, a plain coil-temperature term alike at every distance")
    reveal_needs: ClassVar[dict[str, float]] = {"coil_span_k": 30.0}

    def parameters(self) -> list[Parameter]:
        return [Parameter("former_alpha", 0.0, -1e-4, 3e-4, "1/K", "linear thermal expansion of the coil former",
                          5e-6)]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        finite = np.isfinite(data.x_m)
        span = float(np.ptp(data.t_coil_c[finite])) if finite.any() else 0.0
        positions = len(np.unique(np.round(data.x_m[finite], 6)))
        if span < MIN_SPAN_K or positions < MIN_POSITIONS:
            return {"former_alpha": f"coil temperature span {span:.1f} K over {positions} positions with the target "
                                    f"present (needs {MIN_SPAN_K:g} K and {MIN_POSITIONS})"}
        return {}

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        scale = 1.0 + p["former_alpha"] * (data.t_coil_c - self.sensor.reference_temperature_c)
        return p["p1"] + (x_m - p["p1"]) / scale

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        rise = data.t_coil_c - self.sensor.reference_temperature_c
        scale = 1.0 + p["former_alpha"] * rise
        finite = np.isfinite(x_m)
        offset = np.where(finite, x_m - p["p1"], 0.0)
        own = {"p1": np.where(finite, 1.0 - 1.0 / scale, 0.0), "former_alpha": -offset * rise / scale**2}
        return p["p1"] + (x_m - p["p1"]) / scale, chained(dx, 1.0 / scale, own)
