"""The sensor as the field solution sees it: winding on its former above the plate, then the former's C and G.

Z = [R_wire(T_w) + j w (s L_air + dZ_plate / (j w))] || C_p || G_p, with s = 1 + strain of the former,
dZ_plate from Dodd & Deeds at the effective lift-off (bending included) and the plate's sigma, mu_r
at the temperature under the winding. The reflection coefficient and the lift-off factor are
remembered between readings, so a reading at an unchanged state costs one dot product.
"""

from __future__ import annotations

import math

import numpy as np

from ecds_lab.simulators.physics.coil import CoilSettings
from ecds_lab.simulators.physics.field_solution import kernel, reflection
from ecds_lab.simulators.physics.plate import Plate


class FieldSensor:
    """Coil and plate of the faithful lab; ``impedance`` is called on every bridge reading."""

    def __init__(self, coil: CoilSettings, plate: Plate | None) -> None:
        self.coil = coil
        self.kernel = kernel(coil.winding())
        self.plate = plate
        self.mean_radius_m = 0.5 * (coil.inner_radius_m + coil.outer_radius_m)
        self._reflections: dict[tuple[float, float, float, float], np.ndarray] = {}
        self._decay_key: tuple[float, float] = (math.nan, math.nan)
        self._decay = np.zeros(0)

    def _reflection(self, omega: float, sigma: float, mu_r: float, scale: float) -> np.ndarray:
        key = (omega, sigma, mu_r, scale)
        found = self._reflections.get(key)
        if found is None:
            if len(self._reflections) > 16:
                self._reflections.clear()
            assert self.plate is not None
            found = reflection(self.kernel.a / scale, omega, sigma, mu_r, self.plate.settings.thickness_m)
            self._reflections[key] = found
        return found

    def plate_inductance(self, omega: float, x_m: float, t_plate_c: float, ambient_c: float, scale: float) -> complex:
        """Complex reflected inductance dZ / (j w) (H) of the plate at lift-off x: real part dL, -w imag dR."""
        plate = self.plate
        if plate is None or not math.isfinite(x_m):
            return 0j
        x_eff = x_m - plate.bending_shift_m(x_m, t_plate_c, ambient_c, self.mean_radius_m * scale)
        phi = self._reflection(omega, plate.conductivity(t_plate_c), plate.permeability(t_plate_c), scale)
        if (x_eff, scale) != self._decay_key:
            if x_eff < self.kernel.min_lift_off_m * scale:
                raise ValueError(f"coil-target distance {x_eff * 1e3:.2f} mm is below the field solution's "
                                 f"{self.kernel.min_lift_off_m * 1e3:.0f} mm minimum")
            self._decay = self.kernel.weighted * np.exp(self.kernel.a * (-2.0 * x_eff / scale))
            self._decay_key = (x_eff, scale)
        return scale * complex(np.dot(self._decay, phi))

    def series_branch(self, omega: float, x_m: float, t_winding_c: float, t_plate_c: float, ambient_c: float,
                      strain: float) -> complex:
        """R + jwL of winding and plate (before the former's parallel elements)."""
        scale = 1.0 + strain
        reflected = self.plate_inductance(omega, x_m, t_plate_c, ambient_c, scale)
        l_air = self.kernel.air_inductance_h * scale
        return complex(self.coil.resistance_ohm(t_winding_c), omega * l_air) + 1j * omega * reflected
