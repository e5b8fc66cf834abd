"""Dodd & Deeds field solution: an air-cored coil of rectangular cross-section above a plate.

Dodd, C. V. and Deeds, W. E., "Analytical solutions to eddy-current probe-coil problems",
J. Appl. Phys. 39, 2829 (1968). A coil of N turns, radii r1..r2, height h, whose lower face is
at lift-off x above a plate (conductivity sigma, relative permeability mu_r, thickness t) has

    Z_air   = j w K  int I(a r1, a r2)^2 / a^6 * 2 (a h - 1 + e^{-a h}) da
    dZ      = j w K  int I(a r1, a r2)^2 / a^6 * (1 - e^{-a h})^2 e^{-2 a x} phi(a) da
    K       = pi mu0 N^2 / (h^2 (r2 - r1)^2),   I(a, b) = int_a^b u J1(u) du

with phi the plate's reflection coefficient for the spatial frequency a (``reflection``).
I has the closed form (pi u / 2) (J1(u) H0(u) - J0(u) H1(u)) with Struve functions H0, H1.

Speed: the coil's part of the integrand does not depend on the plate, the frequency or the
distance, so it is tabulated once per geometry on a fixed grid (Gauss-Legendre weights folded in).
A uniform expansion of the former by a factor s maps the geometry (r1, r2, h) -> s (r1, r2, h);
substituting a = b / s gives dZ(s) = s * dZ(b-grid; x / s, phi(b / s)), and L_air(s) = s L_air(1),
so an expanded coil reuses the same table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.special import j0, j1, struve

MU0 = 4e-7 * math.pi

#: The plate term is tabulated for lift-offs down to this distance (e^{-2 a x} below 1e-12 at the top of the grid).
MIN_LIFT_OFF_M = 10e-3


@dataclass(frozen=True)
class Winding:
    """Winding cross-section of the air-cored coil (SI): radii, height, turns."""

    inner_radius_m: float
    outer_radius_m: float
    height_m: float
    turns: int

    def __post_init__(self) -> None:
        if not 0 < self.inner_radius_m < self.outer_radius_m:
            raise ValueError(f"winding radii must satisfy 0 < inner < outer, got {self.inner_radius_m} m "
                             f"and {self.outer_radius_m} m")
        if self.height_m <= 0 or self.turns <= 0:
            raise ValueError(f"winding height and turns must be positive, got {self.height_m} m, {self.turns}")

    @property
    def prefactor(self) -> float:
        """K = pi mu0 N^2 / (h^2 (r2 - r1)^2), H/m (times the integral's m^... gives H)."""
        width = self.outer_radius_m - self.inner_radius_m
        return math.pi * MU0 * self.turns**2 / (self.height_m**2 * width**2)


def bessel_moment(u: np.ndarray) -> np.ndarray:
    """int_0^u t J1(t) dt = (pi u / 2) (J1(u) H0(u) - J0(u) H1(u)) (Struve functions H0, H1)."""
    u = np.asarray(u, float)
    return 0.5 * math.pi * u * (j1(u) * struve(0, u) - j0(u) * struve(1, u))


def _gauss_panels(upper: float, panel_width: float, order: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on (0, upper]: Gauss-Legendre of ``order`` points on panels of ``panel_width``.

    Gauss panels resolve both the oscillation of I (period 2 pi / r2) and the steep e^{-2 a x} near
    a = 0 at large lift-offs with a few hundred nodes.
    """
    panels = max(1, math.ceil(upper / panel_width))
    edges = np.linspace(0.0, upper, panels + 1)
    t, w = np.polynomial.legendre.leggauss(order)
    half = 0.5 * np.diff(edges)
    nodes = (edges[:-1, None] + half[:, None] * (t[None, :] + 1.0)).ravel()
    weights = (half[:, None] * w[None, :]).ravel()
    return nodes, weights


def _cross_section_squared(coil: Winding, a: np.ndarray) -> np.ndarray:
    """I(a r1, a r2)^2 / a^6, with the small-a limit ((r2^3 - r1^3) / 3)^2 / 4 ... via the series."""
    moment = bessel_moment(a * coil.outer_radius_m) - bessel_moment(a * coil.inner_radius_m)
    return (moment / a**3) ** 2


class CoilKernel:
    """The coil's share of the Dodd-Deeds integrands, tabulated once per winding geometry."""

    def __init__(self, coil: Winding, min_lift_off_m: float = MIN_LIFT_OFF_M) -> None:
        self.coil = coil
        # Half an oscillation period of I per panel; range to e^{-2 a x_min} < 1e-12.
        self.a, weights = _gauss_panels(14.0 / min_lift_off_m, math.pi / coil.outer_radius_m)
        self.min_lift_off_m = min_lift_off_m
        shape = _cross_section_squared(coil, self.a) * (1 - np.exp(-self.a * coil.height_m)) ** 2
        self.weighted = coil.prefactor * shape * weights
        self.air_inductance_h = _air_inductance(coil)

    def reflected(self, x_m: float, reflection: np.ndarray, scale: float = 1.0) -> complex:
        """-dZ/(j w) in H: the plate's reflected inductance (complex) at lift-off x for a coil scaled by s."""
        if x_m * 1.0 < self.min_lift_off_m * scale * 0.999:
            raise ValueError(f"lift-off {x_m * 1e3:.2f} mm is below the tabulated minimum "
                             f"{self.min_lift_off_m * 1e3:.1f} mm")
        decay = np.exp(self.a * (-2.0 * x_m / scale))
        return scale * complex(np.dot(self.weighted * decay, reflection))

    def perfect_conductor_delta_l(self, x_m: float, scale: float = 1.0) -> float:
        """Inductance change (H, negative) from a perfectly conducting plate: phi = -1 (image method limit)."""
        return -self.reflected(x_m, np.ones_like(self.a), scale).real


@lru_cache(maxsize=8)
def _air_inductance(coil: Winding) -> float:
    """L of the coil in air (H): the Dodd-Deeds self term with uniform current density."""
    # The self term decays only like a^-4: integrate far out (a h up to ~2000), a dense grid near 0.
    a, weights = _gauss_panels(2000.0 / coil.height_m, math.pi / coil.outer_radius_m)
    ah = a * coil.height_m
    self_term = 2.0 * (ah - 1.0 + np.exp(-ah))
    body = float(np.dot(_cross_section_squared(coil, a) * self_term, weights))
    # Tail beyond the grid: I^2 ~ (2 u / pi) cos^2(...) averages to (r1 + r2) a / pi; times 2 a h / a^6.
    top = a[-1]
    tail = (coil.inner_radius_m + coil.outer_radius_m) / math.pi * 2.0 * coil.height_m / (3.0 * top**3)
    return coil.prefactor * (body + tail)


@lru_cache(maxsize=4)
def kernel(coil: Winding) -> CoilKernel:
    """The tabulated kernel of a winding (cached: the lab evaluates it on every bridge reading)."""
    return CoilKernel(coil)


def reflection(a: np.ndarray, omega: float, sigma_s_per_m: float, mu_r: float, thickness_m: float) -> np.ndarray:
    """Plate reflection coefficient phi(a) of Dodd & Deeds for a plate of finite thickness over air.

    a1 = sqrt(a^2 + j w mu0 mu_r sigma); R0 = (mu_r a - a1) / (mu_r a + a1) is the half-space value;
    a plate of thickness t over air gives phi = R0 (1 - e^{-2 a1 t}) / (1 - R0^2 e^{-2 a1 t}).
    phi -> -1 for a perfect conductor (image method), (mu_r - 1)/(mu_r + 1) for a non-conducting magnet.
    """
    a1 = np.sqrt(a * a + 1j * (omega * MU0 * mu_r * sigma_s_per_m))
    mu_a = mu_r * a
    r0 = (mu_a - a1) / (mu_a + a1)
    if math.isinf(thickness_m):
        return r0
    through = np.exp(-2.0 * thickness_m * a1)
    return r0 * (1.0 - through) / (1.0 - r0 * r0 * through)
