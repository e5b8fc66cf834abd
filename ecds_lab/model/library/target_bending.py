"""target_bending: the hot target bends, so the effective distance shifts with target temperature.

A plate heated from behind bows (its centre or edges move toward or away from the coil). The
coil senses a weighted average of the plate under its winding, and the weights change with
distance, so the effective distance is x - d(dT) w(x): d = b1 dT + b2 dT^2 (m), and
w = 1 + c (x - 60 mm) / 40 mm. b1 > 0: the plate comes closer as it heats.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import Effect, register
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import Tangent, chained
from ecds_lab.model.temperature_levels import curvature_unseen


@register
class TargetBending(Effect):
    name = "target_bending"
    explains = "the hot target bends, shifting the effective distance"
    #: A plate heated from behind bows with its through-thickness gradient g dT: curvature alpha g dT / t, centre
    #: rise alpha g a^2 / (2 t) per kelvin over a half-width a. Over the plates a sensor YAML may describe:
    #: 5 mm copper (alpha 17e-6/K, g ~0.01, a 150 mm) ~0.04 um/K; 5 mm steel (12e-6/K, g 0.15) ~4 um/K;
    #: 1 mm steel ~20 um/K; 1 mm aluminium (23e-6/K, g 0.15) ~40 um/K. So up to tens of um/K on thin
    #: plates (the old +/-20 um/K held for thick ones only), never hundreds: +/-60 um/K.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"bending": (-60e-6, 60e-6),
                                                           "bending_quadratic": (-0.2e-6, 0.2e-6)}
    key_parameters = ("bending",)
    #: The shift is b1 dT + b2 dT^2: with sweeps at two temperatures (a curvature seen only on a heating log at one
    #: position) b1 and b2 trade along b1 + b2 dT_hot, each undetermined while the shift they make is not.
    size_parameters = ("bending", "bending_quadratic")
    reveal = ("measure at two frequencies with the target hot (500 Hz and 15 kHz; on steel two at which its screening "
              "depth's law holds, e.g. 15 and 50 kHz): bending shifts the distance alike at both frequencies, a "
              "conductivity change alters the eddy-current screening most at the lower")
    reveal_needs: ClassVar[dict[str, float]] = {"frequencies_target_hot": 2}

    def parameters(self) -> list[Parameter]:
        return [
            Parameter("bending", 0.0, -1e-4, 1e-4, "m/K", "shift of the effective distance per kelvin of target", 2e-6),
            Parameter("bending_quadratic", 0.0, -1e-6, 1e-6, "m/K^2", "curvature of the shift in target temperature",
                      2e-8),
            Parameter("bending_x", 0.0, -0.9, 0.9, "1", "change of the shift from 60 mm to 100 mm (relative)", 0.1),
        ]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        finite = np.isfinite(data.x_m)
        span = float(np.ptp(data.t_target_c[finite])) if finite.any() else 0.0
        if span < 5:
            return {n: f"target temperature span {span:.1f} K < 5 K with the target present"
                    for n in ("bending", "bending_quadratic", "bending_x")}
        why = curvature_unseen(data.t_target_c[finite])
        return {"bending_quadratic": why} if why is not None else {}

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        d_t = data.t_target_c - self.sensor.reference_temperature_c
        weight = 1 + p["bending_x"] * np.where(np.isfinite(x_m), (x_m - 0.060) / 0.040, 0.0)
        return x_m - (p["bending"] * d_t + p["bending_quadratic"] * d_t**2) * weight

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        d_t = data.t_target_c - self.sensor.reference_temperature_c
        finite = np.isfinite(x_m)
        relative = np.where(finite, (x_m - 0.060) / 0.040, 0.0)
        weight = 1 + p["bending_x"] * relative
        shift = p["bending"] * d_t + p["bending_quadratic"] * d_t**2
        own = {"bending": -d_t * weight, "bending_quadratic": -d_t**2 * weight, "bending_x": -shift * relative}
        return x_m - shift * weight, chained(dx, np.where(finite, 1.0 - shift * p["bending_x"] / 0.040, 1.0), own)
