"""A target tilt that changes with temperature: the plate's mount warps as the plate heats.

The plate is held by a mount on one side (a bracket bolted to its edge). Heated from the plate, the mount's
hot and cold faces expand differently and it bends, tipping the plate about an axis in the plate's plane at
``pivot_mm`` from the coil's axis by

    theta = k (T_target - T_ambient)        (k: ``tilt_urad_per_k``; T_target the plate's thermocouple).

The plate under the coil's axis comes nearer by theta * pivot, and across the coil's face the gap varies:
the winding at azimuth phi (measured from the direction away from the pivot) sees the plate at
x - theta (pivot + r cos phi). Each part of the winding couples to the plate at its own gap, so the coil
sees the average of its coupling over its face,

    dZ_tilted = (1/2 pi) int dZ(x - theta pivot - theta r_c cos phi) dphi,

r_c the winding's mean radius, taken by Gauss-Chebyshev quadrature (``_POINTS`` nodes: exact for the
coupling's expansion in cos phi up to degree 2 ``_POINTS`` - 1). Sizes: a steel bracket 3 mm thick with a
few percent of the plate's rise across it bends by a few to tens of microradians per kelvin; 10 urad/K gives
1.1 mrad at a 110 K rise: the centre 165 um nearer with the pivot at the plate's edge (150 mm), the winding's
rim +-72 um about it.
"""

from __future__ import annotations

import math

from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict

#: Azimuthal nodes over half the coil's face (the tilt's gap is symmetric about the tilt's direction).
_POINTS = 4
#: cos(phi) at the Gauss-Chebyshev nodes of (1/pi) int_0^pi f(cos phi) dphi.
_COSINES = tuple(math.cos((k + 0.5) * math.pi / _POINTS) for k in range(_POINTS))


class TargetTilt(Strict):
    """The plate tilts as it heats, its mount warping (module doc)."""

    enabled: bool = False
    tilt_urad_per_k: float = Field(10.0, ge=-200.0, le=200.0,
                                   description="tilt per kelvin of the plate's rise above ambient (2-50 urad/K)")
    pivot_mm: float = Field(150.0, ge=-500.0, le=500.0,
                            description="distance of the tilt's axis from the coil's axis (the mount at the "
                                        "plate's edge: its half-width); 0: tilting about the centre")


class Tilt:
    """The gaps the winding sees on a tilted plate."""

    def __init__(self, settings: TargetTilt, mean_radius_m: float, ambient_c: float) -> None:
        self.per_k = settings.tilt_urad_per_k * 1e-6
        self.pivot_m = settings.pivot_mm * 1e-3
        self.mean_radius_m = mean_radius_m
        self.ambient_c = ambient_c

    def angle_rad(self, t_target_c: float) -> float:
        return self.per_k * (t_target_c - self.ambient_c)

    def gaps_m(self, x_m: float, t_target_c: float) -> tuple[float, ...] | None:
        """The lift-offs whose couplings average to the tilted plate's (equal weights); None: the plate is flat."""
        theta = self.angle_rad(t_target_c)
        if theta == 0.0 or not math.isfinite(x_m):
            return None
        centre = x_m - theta * self.pivot_m
        rim = theta * self.mean_radius_m
        return tuple(centre - rim * c for c in _COSINES)
