"""A metal object beside the slide: a steel bracket or screw head fixed in the lab near part of the coil's travel.

The object sits at a fixed place: ``radial_mm`` from the slide's axis (the coil's axis), level with the
winding's mid-plane when the coil-target distance is ``position_mm``. As the carriage carries the coil past
it, the coil's field at the object rises and falls, and the object's induced magnetic moment changes the
coil's impedance by

    dZ = j w mu0 4 pi a^3 P(w) |h|^2,

h the coil's field per ampere at the object (the winding's turns as filament loops, each the exact field of a
circular loop: complete elliptic integrals), a the radius of the sphere equivalent to the object and P its
magnetic polarizability (Wait, Geophysics 16, 1951; derivation: the sphere's interior field in modified
spherical Bessel functions i0, i1 matched to an outside dipole):

    P = (2 - Q) / (2 (1 + Q)),   Q = (z i0(z)/i1(z) - 1) / mu_r,   z = a sqrt(j w mu0 mu_r sigma) = (1 + j) a / delta,

with z i0/i1 = z^2 / (z coth z - 1). A non-conducting magnetic object has P = (mu_r - 1)/(mu_r + 2) (L rises);
a perfect conductor P = -1/2 (L falls); steel lies between and moves from the first toward the second as the
skin depth delta falls below a (at 500 Hz delta is 1.0 mm in steel of 5 MS/m, mu_r 100; 0.18 mm at 15 kHz),
with a loss (R rises) in between. The object is small against its distance (a dipole in the coil's field);
the plate's own reaction on the object's field is left out (the object sits near the coil, the plate tens
of mm away). Near the winding's rim |h|^2 falls roughly as 1/r^2, so the change is localized to a few
times the closest distance around ``position_mm``.
"""

from __future__ import annotations

import cmath
import math
from functools import lru_cache

import numpy as np
from pydantic import Field
from scipy.special import ellipe, ellipk

from ecds_lab.simulators.physics._settings import Strict
from ecds_lab.simulators.physics.field_solution import MU0, Winding

#: Filament loops standing for the winding: radial x axial (its turns shared equally).
_RADIAL_FILAMENTS, _AXIAL_FILAMENTS = 40, 6


class MetalObject(Strict):
    """A conducting (and magnetic) object at a fixed place beside the coil's travel (module doc)."""

    enabled: bool = False
    position_mm: float = Field(45.0, gt=0.0, description="coil-target distance at which the winding's mid-plane "
                                                         "is level with the object")
    radial_mm: float = Field(78.5, gt=0.0, description="distance of the object's centre from the coil's axis (the "
                                                       "default coil's winding ends at 75 mm)")
    radius_mm: float = Field(3.0, gt=0.0, le=20.0, description="radius of the equivalent sphere (a screw head, "
                                                               "a bracket's edge: 1-6 mm)")
    conductivity_s_per_m: float = Field(5e6, ge=0.0, le=6e7, description="steel 5e6 (aluminium 3.5e7)")
    mu_r: float = Field(100.0, ge=1.0, le=10000.0, description="relative permeability (steel 100, aluminium 1)")


def polarizability(omega: float, radius_m: float, sigma: float, mu_r: float) -> complex:
    """P(w) of a conducting, permeable sphere in a uniform field: its moment is 4 pi a^3 P H (module doc)."""
    z = radius_m * cmath.sqrt(1j * omega * MU0 * mu_r * sigma)
    if abs(z) < 1e-3:  # z^2 / (z coth z - 1) = 3 + z^2/5 + O(z^4)
        ratio = 3.0 + z * z / 5.0
    else:
        ratio = z * z / (z / cmath.tanh(z) - 1.0)
    q = (ratio - 1.0) / mu_r
    return (2.0 - q) / (2.0 * (1.0 + q))


def loop_field_per_ampere(radius_m: np.ndarray, rho_m: float, z_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(H_rho, H_z) in A/m per ampere of circular loops of ``radius_m`` at a point rho > 0, z from their centres."""
    total = (radius_m + rho_m) ** 2 + z_m**2
    m = 4.0 * radius_m * rho_m / total
    k, e = ellipk(m), ellipe(m)
    near = (radius_m - rho_m) ** 2 + z_m**2
    scale = 1.0 / (2.0 * math.pi * np.sqrt(total))
    h_z = (k + (radius_m**2 - rho_m**2 - z_m**2) / near * e) * scale
    h_rho = z_m / rho_m * (-k + (radius_m**2 + rho_m**2 + z_m**2) / near * e) * scale
    return h_rho, h_z


class MetalObjectNearby:
    """The object's change of the coil's complex inductance (H) for a carriage at coil-target distance x."""

    def __init__(self, settings: MetalObject, winding: Winding) -> None:
        self.settings = settings
        self.position_m = settings.position_mm * 1e-3
        self.radial_m = settings.radial_mm * 1e-3
        self.radius_m = settings.radius_mm * 1e-3
        self.height_m = winding.height_m
        # Filaments at the centres of equal cells of the winding's cross-section.
        radial = np.linspace(winding.inner_radius_m, winding.outer_radius_m, 2 * _RADIAL_FILAMENTS + 1)[1::2]
        axial = np.linspace(0.0, winding.height_m, 2 * _AXIAL_FILAMENTS + 1)[1::2]
        self.filament_radii, self.filament_heights = (grid.ravel() for grid in np.meshgrid(radial, axial))
        self.turns_per_filament = winding.turns / self.filament_radii.size
        self.volume_factor = MU0 * 4.0 * math.pi * self.radius_m**3
        self._polarizability = lru_cache(maxsize=16)(self._polarizability_at)
        self._field_squared = lru_cache(maxsize=256)(self._field_squared_at)

    def _polarizability_at(self, omega: float) -> complex:
        s = self.settings
        return polarizability(omega, self.radius_m, s.conductivity_s_per_m, s.mu_r)

    def _field_squared_at(self, x_m: float) -> float:
        """|h|^2 at the object ((A/m)^2 per A^2) for the coil's lower face at x above the plate."""
        z_object = self.position_m + 0.5 * self.height_m - x_m  # above the winding's lower face
        h_rho, h_z = loop_field_per_ampere(self.filament_radii, self.radial_m, z_object - self.filament_heights)
        return float(h_rho.sum() ** 2 + h_z.sum() ** 2) * self.turns_per_filament**2

    def inductance_h(self, omega: float, x_m: float) -> complex:
        """dL (complex, H): the real part adds to L, -w times the imaginary part to R."""
        return self.volume_factor * self._polarizability(omega) * self._field_squared(x_m)
