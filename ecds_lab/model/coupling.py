"""Coupling k(x) between the coil and an ideal (superconducting) target.

Image method (docs/physics.md): a perfect conductor at distance x mirrors the coil
at 2x with opposite current, so L_eff = L - M(2x) and k(x)^2 = M_image(x) / L.
M comes from Maxwell's formula for coaxial circular filaments, summed over a
filament grid of the winding. The result is tabulated once per geometry and
interpolated (vectorised), or read from a user's table (e.g. a FEM export).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.special import ellipe, ellipk

from ecds_lab.data.sensor import CoilGeometry

MU0 = 4e-7 * np.pi
_X_GRID_M = np.geomspace(1e-4, 2.0, 600)


def maxwell_mutual_inductance(a: np.ndarray, b: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Mutual inductance of coaxial circular filaments, radii a and b, axial distance d (all m).

    M = mu0 sqrt(ab) [(2/k - k) K(k) - (2/k) E(k)],  k^2 = 4ab / ((a+b)^2 + d^2).
    """
    a, b, d = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float), np.asarray(d, float))
    m = 4 * a * b / ((a + b) ** 2 + d**2)
    k = np.sqrt(m)
    return MU0 * np.sqrt(a * b) * ((2 / k - k) * ellipk(m) - (2 / k) * ellipe(m))


def _filaments(coil: CoilGeometry) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Centres (radius, depth below the coil face) of a filament grid; cell width and height."""
    dr = (coil.outer_radius_m - coil.inner_radius_m) / coil.radial_filaments
    dz = coil.height_m / coil.axial_filaments
    r = coil.inner_radius_m + dr * (np.arange(coil.radial_filaments) + 0.5)
    z = dz * (np.arange(coil.axial_filaments) + 0.5)
    rr, zz = np.meshgrid(r, z, indexing="ij")
    return rr.ravel(), zz.ravel(), dr, dz


def self_inductance(coil: CoilGeometry) -> float:
    """Self-inductance of the winding (H): filament sum, each cell's own loop with its GMD radius."""
    r, z, dr, dz = _filaments(coil)
    turns = coil.turns / r.size
    ri, rj = np.meshgrid(r, r, indexing="ij")
    zi, zj = np.meshgrid(z, z, indexing="ij")
    off = ~np.eye(r.size, dtype=bool)
    mutual = maxwell_mutual_inductance(ri[off], rj[off], np.abs(zi - zj)[off]).sum()
    gmd = 0.2235 * (dr + dz)  # geometric mean distance of a rectangular cell from itself
    own = (MU0 * r * (np.log(8 * r / gmd) - 1.75)).sum()
    return float(turns**2 * (mutual + own))


def image_mutual_inductance(coil: CoilGeometry, x_m: np.ndarray) -> np.ndarray:
    """M between the coil and its mirror image in a perfect conductor at distance x (H)."""
    r, z, _, _ = _filaments(coil)
    turns = coil.turns / r.size
    ri, rj = np.meshgrid(r, r, indexing="ij")
    zsum = (z[:, None] + z[None, :]).ravel()
    ri, rj = ri.ravel(), rj.ravel()
    x = np.atleast_1d(np.asarray(x_m, float))
    d = 2 * x[:, None] + zsum[None, :]
    return turns**2 * maxwell_mutual_inductance(ri[None, :], rj[None, :], d).sum(axis=1)


class Coupling:
    """k(x) for one sensor: vectorised, cheap to evaluate, zero beyond its table."""

    def __init__(self, x_m: np.ndarray, k: np.ndarray, source: str) -> None:
        order = np.argsort(x_m)
        self.x_m = np.asarray(x_m, float)[order]
        self.k = np.asarray(k, float)[order]
        self.source = source
        self._interp = PchipInterpolator(self.x_m, self.k, extrapolate=False)
        self._derivative = self._interp.derivative()
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def __call__(self, x_m: np.ndarray | float) -> np.ndarray:
        """k at distance x (m); inf means the coil in air (k = 0). The last result is kept (read-only) for the same
        distances: a solver's Jacobian asks for k where it just asked for the prediction."""
        x = np.asarray(x_m, float)
        last = self._last
        if last is not None and last[0].shape == x.shape and np.array_equal(last[0], x):
            return last[1]
        out = self._interp(np.clip(x, self.x_m[0], None))
        out = np.where(np.isfinite(out), out, 0.0)
        out.flags.writeable = False
        self._last = (x.copy(), out)
        return out

    def derivative(self, x_m: np.ndarray | float) -> np.ndarray:
        x = np.asarray(x_m, float)
        out = self._derivative(np.clip(x, self.x_m[0], None))
        return np.where(np.isfinite(out), out, 0.0)


@lru_cache(maxsize=16)
def image_method_coupling(coil: CoilGeometry) -> Coupling:
    """Tabulate k(x) = sqrt(M_image(x) / L) once per coil geometry."""
    k2 = image_mutual_inductance(coil, _X_GRID_M) / self_inductance(coil)
    return Coupling(_X_GRID_M, np.sqrt(np.clip(k2, 0, None)), "image method")


def table_coupling(path: Path) -> Coupling:
    """k(x) from a user's CSV with columns x_mm,k (e.g. exported from a field simulation)."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    missing = {"x_mm", "k"} - set(data.dtype.names or ())
    if missing:
        raise ValueError(f"{path}: coupling table needs columns x_mm,k; missing {sorted(missing)}")
    return Coupling(data["x_mm"] * 1e-3, data["k"], f"table {path}")
