"""The sensor as the field solution sees it: winding on its former above the plate, then the former's C and G.

Z = [R_wire(T_w) + j w (s L_air + dZ_plate / (j w))] || C_p || G_p, with s = 1 + strain of the former,
dZ_plate from Dodd & Deeds at the effective lift-off (bending included) and the plate's sigma, mu_r
at the temperature under the winding. The reflection coefficient and the lift-off factor are
remembered between readings, so a reading at an unchanged state costs one dot product; the series
branch itself is memoised on its arguments (a sweep reads the same state many times in a row).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ecds_lab.simulators.physics.coil import CoilSettings
from ecds_lab.simulators.physics.field_solution import kernel, reflection
from ecds_lab.simulators.physics.plate import Plate

#: Grid cut-off: nodes with a x beyond this (e^{-2 a x} < 1e-13) are left out of the plate integral.
CUTOFF = 15.0
#: Series branches remembered (per frequency and state, the least recently used forgotten first).
MEMO_SIZE = 64


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
        self._branches = lru_cache(maxsize=MEMO_SIZE)(self._series_branch)

    def _reflection(self, omega: float, sigma: float, mu_r: float, scale: float, nodes: int) -> np.ndarray:
        """phi at the first ``nodes`` spatial frequencies (remembered per plate state and frequency)."""
        key = (omega, sigma, mu_r, scale)
        found = self._reflections.get(key)
        if found is None or found.size < nodes:
            if len(self._reflections) > 16:
                self._reflections.clear()
            assert self.plate is not None
            found = reflection(self.kernel.a[:nodes] / scale, omega, sigma, mu_r, self.plate.settings.thickness_m)
            self._reflections[key] = found
        return found[:nodes]

    def plate_inductance(self, omega: float, x_m: float, t_plate_c: float, ambient_c: float, scale: float) -> complex:
        """Complex reflected inductance dZ / (j w) (H) of the plate at lift-off x: real part dL, -w imag dR."""
        plate = self.plate
        if plate is None or not math.isfinite(x_m):
            return 0j
        x_eff = x_m - plate.bending_shift_m(x_m, t_plate_c, ambient_c, self.mean_radius_m * scale)
        if (x_eff, scale) != self._decay_key:
            if x_eff < self.kernel.min_lift_off_m * scale:
                raise ValueError(f"coil-target distance {x_eff * 1e3:.2f} mm is below the field solution's "
                                 f"{self.kernel.min_lift_off_m * 1e3:.0f} mm minimum")
            # Only the spatial frequencies where e^{-2 a x} is above 1e-13 of its start contribute.
            nodes = int(np.searchsorted(self.kernel.a, CUTOFF * scale / x_eff)) + 1
            a = self.kernel.a[:nodes]
            self._decay = self.kernel.weighted[:nodes] * np.exp(a * (-2.0 * x_eff / scale))
            self._decay_key = (x_eff, scale)
        phi = self._reflection(omega, plate.conductivity(t_plate_c), plate.permeability(t_plate_c), scale,
                               self._decay.size)
        return scale * complex(np.dot(self._decay, phi))

    def series_branch(self, omega: float, x_m: float, t_winding_c: float, t_plate_c: float, ambient_c: float,
                      strain: float) -> complex:
        """R + jwL of winding and plate (before the former's parallel elements).

        Memoised: for this sensor's coil and plate the branch is a pure function of the arguments, so a
        remembered value is exactly what computing it again would give, whatever was asked in between.
        """
        return self._branches(omega, x_m, t_winding_c, t_plate_c, ambient_c, strain)

    def _series_branch(self, omega: float, x_m: float, t_winding_c: float, t_plate_c: float, ambient_c: float,
                       strain: float) -> complex:
        scale = 1.0 + strain
        reflected = self.plate_inductance(omega, x_m, t_plate_c, ambient_c, scale)
        l_air = self.kernel.air_inductance_h * scale
        return complex(self.coil.resistance_ohm(t_winding_c), omega * l_air) + 1j * omega * reflected
