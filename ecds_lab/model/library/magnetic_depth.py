"""magnetic_depth: a magnetic plate (steel) screens the coil's field from a complex depth behind its face.

Dodd & Deeds' reflection coefficient of a thick plate of permeability mu_r, -phi = (1 - u)/(1 + u) with
u = mu_r alpha/gamma (alpha the field's spatial frequency, gamma = (1 + j)/delta), is exp(-2 alpha c) to first
order in u: the plate reflects like a perfect conductor at the complex depth c = mu_r/gamma = D (1 - j) behind its
face, D = mu_r delta/2 = sqrt(mu_r/(2 omega mu_0 sigma)) (docs/physics.md, "A magnetic plate"). The coil therefore
senses Re k^2(x + c) = k^2(x + D) - D^2/2 d^2k^2/dx^2 + O(D^3) (the reflection's u^3 term): beside a shift of
the distance (which one frequency's calibration offset p1 takes), a curvature of k^2 in x that no calibration of
Eq. (5) follows and the ECM's single loop lacks. The fitted D is an effective one (its next terms are not small at
20 mm; docs/physics.md). Copper's depth is its skin depth's half (a fraction of a millimetre at 15 kHz, the
``plate_recession`` effect); steel's mu_r of about 100 makes D about 9 mm at 15 kHz, where the curvature changes
L by hundreds of ppm between 20 and 100 mm.

The one parameter, ``magnetic_depth``, is D at 15 kHz, the frequency the paper measured steel at; D ~ f^-1/2 (mu_r
and sigma do not depend on frequency).
The first-order form holds while D is small against the coil's radius, i.e. at high frequency (steel at 15 kHz:
D alpha ~ 0.1-0.3); at 500 Hz steel's D (about 50 mm) is as large as the coil and its magnetic and eddy-current
responses nearly cancel: no first-order law describes that, and the effect does not claim to.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import NON_MAGNETIC_RESISTIVITY_OHM_M, SensorConfig
from ecds_lab.model.effects import Effect, Inputs, register
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import InputTangents, Tangent, plus, scaled

#: The frequency ``magnetic_depth`` is stated at (Hz).
REFERENCE_HZ = 15e3
#: Spacing (m) of the second difference that gives d^2k^2/dx^2: the coupling's scale at 20 mm is ~20 mm, so its own
#: error, h^2/12 of the fourth derivative, stays near 1e-2 of the term.
STEP_M = 2e-3
#: Steel's mu_r ~ 100 and sigma ~ 5 MS/m (docs/physics.md) give D = sqrt(mu_r/(2 omega mu_0 sigma)) = 9.2 mm at 15 kHz.
STEEL_DEPTH_M = 9.2e-3


#: The first-order law holds while D is small against the coil: D at most this share of the winding's mean radius.
#: The textbook steel before the paper's coil: 0.14 at 15 kHz, 0.25 at 5 kHz, 0.78 at 500 Hz (magnetisation and eddy
#: currents nearly cancel). On the faithful lab's steel plate bending as it heats (measured 2026-11-30), sweeps at 15
#: and 50 kHz are fitted to the noise with this law and a bending (15.4 ppm against 15.5), at 15 and 5 kHz the
#: same search leaves 114 ppm and claims nothing.
MAX_DEPTH_SHARE = 0.15


def per_frequency(freq_hz: np.ndarray) -> np.ndarray:
    """D(f)/D(15 kHz) = sqrt(15 kHz/f)."""
    return np.sqrt(REFERENCE_HZ / freq_hz)


def is_magnetic(sensor: SensorConfig) -> bool:
    """A target whose screening depth is mu_r delta/2 (steel), not copper's skin depth's half."""
    return sensor.target not in NON_MAGNETIC_RESISTIVITY_OHM_M


def lowest_frequency_hz(sensor: SensorConfig) -> float:
    """The lowest frequency at which this law describes the sensor's plate (0: a non-magnetic one, any frequency):
    there the textbook steel's D reaches MAX_DEPTH_SHARE of the winding's mean radius (D ~ f^-1/2). The paper's
    coil: 13.4 kHz; what a campaign or a plan asks below it, no fit of this law can answer."""
    if not is_magnetic(sensor):
        return 0.0
    radius = 0.5 * (sensor.coil.inner_radius_m + sensor.coil.outer_radius_m)
    return REFERENCE_HZ * (STEEL_DEPTH_M / (MAX_DEPTH_SHARE * radius)) ** 2


def depth_parameter(sensor: SensorConfig) -> Parameter:
    """D at 15 kHz, started at the textbook steel's (on a copper plate at 0, where it is held: no action at all)."""
    return Parameter("magnetic_depth", STEEL_DEPTH_M if is_magnetic(sensor) else 0.0, 0.0, 0.2, "m",
                     "a magnetic plate's screening depth mu_r delta/2 at 15 kHz (D ~ f^-1/2)", 1e-3)


def curvature(k2: np.ndarray, x_m: np.ndarray, coupling_hat: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """d^2k^2/dx^2 at ``x_m`` (``k2`` there) by a second difference of the calibrated coupling."""
    h = STEP_M
    return (coupling_hat(x_m + h) ** 2 - 2 * k2 + coupling_hat(x_m - h) ** 2) / h**2


def curvature_and_tangent(k2: np.ndarray, dk2: Tangent, x_m: np.ndarray, dx: Tangent,
                          coupling_hat_tangent: Callable[[np.ndarray, Tangent], tuple[np.ndarray, Tangent]]
                          ) -> tuple[np.ndarray, Tangent]:
    """``curvature`` and its tangent, given k^2's (``dk2``) and the distance's (``dx``)."""
    h = STEP_M
    up, d_up = coupling_hat_tangent(x_m + h, dx)
    down, d_down = coupling_hat_tangent(x_m - h, dx)
    return ((up**2 - 2 * k2 + down**2) / h**2,
            plus(scaled(d_up, 2 * up / h**2), scaled(dk2, -2 / h**2), scaled(d_down, 2 * down / h**2)))


def deepened(k2: np.ndarray, dk2: Tangent, bent: np.ndarray, d_bent: Tangent, hot: np.ndarray, cold: np.ndarray,
             d_hot: Tangent, d_cold: Tangent) -> tuple[np.ndarray, Tangent]:
    """k^2 with the curvature of depth ``hot`` in place of that of ``cold`` (zero: none), -(hot^2 - cold^2)/2 times
    ``bent`` (d^2k^2/dx^2), and its tangent (the depths' tangents ``d_hot``, ``d_cold``)."""
    return (k2 - 0.5 * (hot**2 - cold**2) * bent,
            plus(dk2, scaled(d_bent, -0.5 * (hot**2 - cold**2)), scaled(d_hot, -hot * bent),
                 scaled(d_cold, cold * bent)))


@register
class MagneticDepth(Effect):
    name = "magnetic_depth"
    explains = ("a magnetic plate screens the coil's field from a complex depth mu_r delta/2 (1 - j) behind its face: "
                "beside a shift of the distance, a curvature of k^2 in x the ECM's single loop lacks")
    #: D = sqrt(mu_r/(2 omega mu_0 sigma)) at 15 kHz: structural and electrical steels (mu_r 20-2000 at the small
    #: fields of a sensor, sigma 1-10 MS/m) span 2.9-92 mm; ferritic stainless and cast iron lie inside.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"magnetic_depth": (2.9e-3, 0.092)}
    key_parameters = ("magnetic_depth",)
    #: The depth the textbook steel predicts is where fits start; zero is no magnetic action at all.
    absent_form: ClassVar[dict[str, float]] = {"magnetic_depth": 0.0}
    alternative_starts: ClassVar[tuple[dict[str, float], ...]] = ({"magnetic_depth": 3.3e-3}, {"magnetic_depth": 25e-3})
    reveal = ("measure the steel plate at 15 kHz at positions a few mm apart from 20 to 60 mm, where the curvature of "
              "k^2 the magnetic depth adds is largest")

    @classmethod
    def applies_to(cls, sensor: SensorConfig) -> bool:
        return is_magnetic(sensor)

    #: One plate: ``target_tau_temperature``'s depth on a magnetic plate, which follows its conductivity.
    shared_parameters = ("magnetic_depth",)

    def parameters(self) -> list[Parameter]:
        return [depth_parameter(self.sensor)]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        if not self.applies_to(self.sensor):
            return {"magnetic_depth": f"a non-magnetic target ({self.sensor.target}): its screening depth is the skin "
                                      "depth's half (plate_recession)"}
        if not np.isfinite(data.x_m).any():
            return {"magnetic_depth": "no data with the target present"}
        return {}

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        return self.d_effective_distance(x_m, {}, data, p)[0]

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        """The set-back beyond its value at 15 kHz, which the calibration's offset p1 holds: a fit started from a
        baseline's calibration at 15 kHz starts where it was, not 9 mm off it."""
        beyond = per_frequency(data.freq_hz) - 1.0
        return x_m + p["magnetic_depth"] * beyond, plus(dx, {"magnetic_depth": beyond})

    def coupling_squared(self, k2: np.ndarray, inputs: Inputs, data: Measurements, p: Mapping[str, float],
                         coupling_hat: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        depth = p["magnetic_depth"] * per_frequency(data.freq_hz)
        return k2 - 0.5 * depth**2 * curvature(k2, inputs.x_m, coupling_hat)

    def d_coupling_squared(self, k2: np.ndarray, dk2: Tangent, inputs: Inputs, d_inputs: InputTangents,
                           data: Measurements, p: Mapping[str, float],
                           coupling_hat_tangent: Callable[[np.ndarray, Tangent], tuple[np.ndarray, Tangent]]
                           ) -> tuple[np.ndarray, Tangent]:
        bent, d_bent = curvature_and_tangent(k2, dk2, inputs.x_m, d_inputs.x_m, coupling_hat_tangent)
        per = per_frequency(data.freq_hz)
        return deepened(k2, dk2, bent, d_bent, p["magnetic_depth"] * per, np.zeros_like(k2), {"magnetic_depth": per},
                        {})
