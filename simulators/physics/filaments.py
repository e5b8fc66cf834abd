"""Maxwell's formula for coaxial circular filaments and filament sums over a winding.

M = mu0 sqrt(ab) [(2/k - k) K(k) - (2/k) E(k)], k^2 = 4ab / ((a+b)^2 + d^2) (Maxwell, Treatise
Vol. II, Art. 701; Grover, Inductance Calculations, 1946). A winding is split into a grid of
filaments at the centres of equal rectangular cells, each carrying N / cells turns. A cell's
own loop uses the round-wire loop formula mu0 a (ln(8a/rho) - 7/4) with rho the geometric mean
distance of the rectangle from itself, 0.2235 (width + height) (Grover).
"""

from __future__ import annotations

import numpy as np
from scipy.special import ellipe, ellipk

from ecds_lab.simulators.physics.field_solution import MU0, Winding


def maxwell_mutual(a: np.ndarray, b: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Mutual inductance (H) of coaxial circular filaments of radii a, b at axial distance d (m)."""
    a, b, d = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float), np.asarray(d, float))
    m = 4.0 * a * b / ((a + b) ** 2 + d * d)
    k = np.sqrt(m)
    return MU0 * np.sqrt(a * b) * ((2.0 / k - k) * ellipk(m) - (2.0 / k) * ellipe(m))


def filament_grid(coil: Winding, radial: int, axial: int) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Cell centres (radius, height above the coil's lower face), flattened; cell width and height."""
    dr = (coil.outer_radius_m - coil.inner_radius_m) / radial
    dz = coil.height_m / axial
    r = coil.inner_radius_m + dr * (np.arange(radial) + 0.5)
    z = dz * (np.arange(axial) + 0.5)
    rr, zz = np.meshgrid(r, z, indexing="ij")
    return rr.ravel(), zz.ravel(), dr, dz


def self_inductance(coil: Winding, radial: int, axial: int) -> float:
    """L of the winding in air (H) as a filament sum with the cells' own loops."""
    r, z, dr, dz = filament_grid(coil, radial, axial)
    per_cell = coil.turns / r.size
    off = ~np.eye(r.size, dtype=bool)
    mutual = maxwell_mutual(r[:, None], r[None, :], np.abs(z[:, None] - z[None, :]))[off].sum()
    gmd = 0.2235 * (dr + dz)
    own = (MU0 * r * (np.log(8.0 * r / gmd) - 1.75)).sum()
    return float(per_cell**2 * (mutual + own))


def image_mutual(coil: Winding, x_m: float, radial: int, axial: int) -> float:
    """M (H) between the winding (lower face at lift-off x) and its mirror image in a plane conductor."""
    r, z, _, _ = filament_grid(coil, radial, axial)
    per_cell = coil.turns / r.size
    d = 2.0 * x_m + z[:, None] + z[None, :]
    return float(per_cell**2 * maxwell_mutual(r[:, None], r[None, :], d).sum())
