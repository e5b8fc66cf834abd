"""The target plate: conductivity and permeability with temperature, thickness, gradient, bending.

Materials (paper Sec. 3.1): copper sigma = 58 MS/m at 20 C with resistivity rising 0.39 %/K; steel
sigma 5 -> 3 MS/m and mu_r 100 -> 200 over about 100 K, i.e. resistivity +0.667 %/K and mu_r +1 %/K
(linear). The paper gives no plate thickness: 5 mm is taken for both (copper's skin depth is
2.9 mm at 500 Hz and 0.53 mm at 15 kHz, steel's under 1 mm at 500 Hz, so 5 mm plates behave almost
as thick ones; documented in docs/simulated_lab.md).

Gradient (paper Sec. 3.2): heaters at the plate's corners; steel (45 W/mK) keeps a gradient, so the
region under the winding is hotter than the thermocouple by a fraction of the plate's rise; copper
(400 W/mK) is almost uniform.

Bending (paper Sec. 3.2, Fig. 13-15): the hot plate's edges bend away from the coil, i.e. the plate
domes toward it. A paraboloid of centre rise w0 = b (T - T_amb) over a plate of half-width a is seen
by the coil weighted where its field meets the plate: the mean squared radius of that footprint is
about r_c^2 + x^2 (r_c the winding's mean radius), so the effective distance falls by
w0 (1 - (r_c^2 + x^2) / a^2): most near the plate (negative position error below ~50 mm), less far away.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict

PlateMaterial = Literal["copper", "steel"]

#: (sigma at 20 C in S/m, resistivity tempco 1/K, mu_r at 20 C, mu_r tempco 1/K, surface lag s, gradient fraction)
MATERIALS: dict[str, tuple[float, float, float, float, float, float]] = {
    "copper": (58e6, 0.0039, 1.0, 0.0, 30.0, 0.01),
    "steel": (5e6, (5.0 / 3.0 - 1.0) / 100.0, 100.0, 0.01, 180.0, 0.15),
}


class Conductivity(Strict):
    """sigma(T) = sigma20 / (1 + tempco (T - 20 C)); off: the plate keeps its 20 C conductivity."""

    enabled: bool = True
    sigma_20c_s_per_m: float | None = Field(None, gt=0, description="default: copper 58e6, steel 5e6")
    resistivity_tempco_per_k: float | None = Field(None, description="default: copper 0.0039, steel 0.00667")


class Permeability(Strict):
    """mu_r(T) = mu_r20 (1 + tempco (T - 20 C)); off: the plate keeps its 20 C permeability."""

    enabled: bool = True
    mu_r_20c: float | None = Field(None, ge=1, description="default: copper 1, steel 100")
    tempco_per_k: float | None = Field(None, description="default: copper 0, steel 0.01 (100 -> 200 over 100 K)")


class Gradient(Strict):
    """The plate under the winding runs hotter than the thermocouple by ``fraction`` of the plate's rise."""

    enabled: bool = True
    fraction: float | None = Field(None, description="default: copper 0.01, steel 0.15")


class Bending(Strict):
    """The hot plate domes toward the coil: centre rise b (T - T_amb), seen edge-weighted (module doc)."""

    enabled: bool = True
    centre_rise_um_per_k: float = Field(0.8, description="0.8 um/K: 88 um at 110 K (sized to paper Fig. 14)")
    half_width_m: float = Field(0.15, gt=0, description="plate 300 mm square (not in the paper)")


class PlateSettings(Strict):
    """The target plate."""

    material: PlateMaterial | None = Field(None, description="default: the sensor description's target")
    thickness_m: float = Field(5e-3, gt=0, description="not in the paper; 5 mm (module doc)")
    conductivity: Conductivity = Conductivity()
    permeability: Permeability = Permeability()
    gradient: Gradient = Gradient()
    bending: Bending = Bending()
    surface_lag_s: float | None = Field(None, gt=0, description="thermocouple surface behind the heated bulk; "
                                                                 "default copper 30 s, steel 180 s")


class Plate:
    """Material laws of one plate, resolved from its settings and material defaults."""

    def __init__(self, settings: PlateSettings, material: str) -> None:
        self.settings, self.material = settings, material
        sigma, rho_tc, mu, mu_tc, lag, gradient = MATERIALS[material]
        c, p = settings.conductivity, settings.permeability
        self.sigma20 = c.sigma_20c_s_per_m if c.sigma_20c_s_per_m is not None else sigma
        self.rho_tempco = (c.resistivity_tempco_per_k if c.resistivity_tempco_per_k is not None else rho_tc) \
            if c.enabled else 0.0
        self.mu20 = p.mu_r_20c if p.mu_r_20c is not None else mu
        self.mu_tempco = (p.tempco_per_k if p.tempco_per_k is not None else mu_tc) if p.enabled else 0.0
        self.surface_lag_s = settings.surface_lag_s if settings.surface_lag_s is not None else lag
        g = settings.gradient
        self.gradient = (g.fraction if g.fraction is not None else gradient) if g.enabled else 0.0

    def conductivity(self, t_c: float) -> float:
        return self.sigma20 / (1.0 + self.rho_tempco * (t_c - 20.0))

    def permeability(self, t_c: float) -> float:
        return self.mu20 * (1.0 + self.mu_tempco * (t_c - 20.0))

    def field_temperature_c(self, t_surface_c: float, ambient_c: float) -> float:
        """Temperature of the plate under the winding, from the thermocouple's surface reading."""
        return t_surface_c + self.gradient * (t_surface_c - ambient_c)

    def bending_shift_m(self, x_m: float, t_c: float, ambient_c: float, mean_radius_m: float) -> float:
        """How much nearer the coil the bent plate effectively is (m, >= 0 when hot)."""
        b = self.settings.bending
        if not b.enabled:
            return 0.0
        rise = b.centre_rise_um_per_k * 1e-6 * (t_c - ambient_c)
        footprint = (mean_radius_m**2 + x_m**2) / b.half_width_m**2
        return rise * max(0.0, 1.0 - footprint)
