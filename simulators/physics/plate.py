"""The target plate: conductivity and permeability with temperature, thickness, gradient, bending.

Materials (paper Sec. 3.1): copper sigma = 58 MS/m at 20 C with resistivity rising 0.39 %/K; steel
sigma 5 -> 3 MS/m and mu_r 100 -> 200 over about 100 K, i.e. resistivity +0.667 %/K and mu_r +1 %/K
(linear). Not in the paper, from handbooks (``MATERIALS``): pure aluminium 37.7 MS/m, +0.43 %/K; a common
brass (CuZn37, C27200) 15.5 MS/m, +0.15 %/K; both non-magnetic (mu_r 1). The paper gives no plate thickness:
5 mm is taken for every plate (copper's skin depth is 2.9 mm at 500 Hz and 0.53 mm at 15 kHz, steel's under
1 mm at 500 Hz, so 5 mm plates behave almost as thick ones; aluminium's is 3.7 mm, brass's 5.7 mm at 500 Hz,
so there the brass plate is partly transparent; documented in docs/simulated_lab.md).

Gradient (paper Sec. 3.2): heaters at the plate's corners; steel (45 W/mK) keeps a gradient, so the
region under the winding is hotter than the thermocouple by a fraction of the plate's rise; copper
(400 W/mK) is almost uniform. The plates the paper did not heat take copper's figures scaled by their
handbook thermal properties (``_like_copper``).

Bending (paper Sec. 3.2, Fig. 13-15): the hot plate's edges bend away from the coil, i.e. the plate
domes toward it. A paraboloid of centre rise w0 = b (T - T_amb) over a plate of half-width a is seen
by the coil weighted where its field meets the plate: the mean squared radius of that footprint is
about r_c^2 + x^2 (r_c the winding's mean radius), so the effective distance falls by
w0 (1 - (r_c^2 + x^2) / a^2): most near the plate (negative position error below ~50 mm), less far away.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from pydantic import Field, field_validator

from ecds_lab.simulators.physics._settings import Strict

PlateMaterial = Literal["copper", "aluminium", "brass", "steel"]


@dataclass(frozen=True)
class Material:
    """One plate material: its handbook figures and the plate block's defaults for it."""

    sigma_20c_s_per_m: float
    resistivity_tempco_per_k: float
    mu_r_20c: float
    mu_r_tempco_per_k: float
    #: Thermal conductivity (W/mK), diffusivity k / (density c_p) (m^2/s) and linear expansion (1/K), near room
    #: temperature.
    thermal_conductivity_w_per_mk: float
    thermal_diffusivity_m2_per_s: float
    expansion_per_k: float
    #: The thermocouple's surface behind the heated bulk (s), the rise under the winding beyond the
    #: thermocouple's (fraction of the plate's rise) and the centre rise of the bending dome (um/K).
    surface_lag_s: float
    gradient_fraction: float
    bending_um_per_k: float


def _diffusivity(conductivity_w_per_mk: float, density_kg_per_m3: float, heat_capacity_j_per_kgk: float) -> float:
    return conductivity_w_per_mk / (density_kg_per_m3 * heat_capacity_j_per_kgk)


#: The paper's copper plate: sigma and tempco paper Sec. 3.1 (58 MS/m = 100 % IACS, +0.39 %/K); 400 W/mK
#: (paper Sec. 3.2); 8960 kg/m^3, 385 J/kgK and 16.5e-6/K (CRC Handbook, 25 C). Lag 30 s, gradient 0.01 and
#: bending 0.8 um/K are this lab's choices (the bending sized to paper Fig. 14, docs/simulated_lab.md).
COPPER = Material(58e6, 0.0039, 1.0, 0.0, 400.0, _diffusivity(400.0, 8960.0, 385.0), 16.5e-6,
                  surface_lag_s=30.0, gradient_fraction=0.01, bending_um_per_k=0.8)

#: The paper's steel plate: sigma 5 -> 3 MS/m (resistivity +0.667 %/K) and mu_r 100 -> 200 over about 100 K
#: (paper Sec. 3.1); 45 W/mK (paper Sec. 3.2); 7850 kg/m^3, 470 J/kgK, 12e-6/K (mild steel, handbook). Lag 180 s
#: and gradient 0.15 are this lab's choices for the poor conductor (paper Sec. 3.2); the bending keeps copper's
#: 0.8 um/K (the paper sizes no bending; the lab's steel plate has always domed as its copper one).
STEEL = Material(5e6, (5.0 / 3.0 - 1.0) / 100.0, 100.0, 0.01, 45.0, _diffusivity(45.0, 7850.0, 470.0), 12e-6,
                 surface_lag_s=180.0, gradient_fraction=0.15, bending_um_per_k=0.8)


def _like_copper(sigma_20c_s_per_m: float, resistivity_tempco_per_k: float, conductivity_w_per_mk: float,
                 density_kg_per_m3: float, heat_capacity_j_per_kgk: float, expansion_per_k: float) -> Material:
    """A non-magnetic plate the paper did not use, in copper's place (same size, heaters and mount).

    Its thermal defaults are copper's scaled by the laws behind them: the surface lags the bulk by a
    diffusion time, ~ 1/diffusivity; the gradient under the corner heaters is the heat flow's drop over the
    plate, ~ 1/thermal conductivity, against a rise set by the surface losses (the same for every metal);
    the dome is the plate's thermal strain in its mount, ~ the expansion coefficient.
    """
    diffusivity = _diffusivity(conductivity_w_per_mk, density_kg_per_m3, heat_capacity_j_per_kgk)
    return Material(
        sigma_20c_s_per_m, resistivity_tempco_per_k, 1.0, 0.0, conductivity_w_per_mk, diffusivity, expansion_per_k,
        surface_lag_s=COPPER.surface_lag_s * COPPER.thermal_diffusivity_m2_per_s / diffusivity,
        gradient_fraction=COPPER.gradient_fraction * COPPER.thermal_conductivity_w_per_mk / conductivity_w_per_mk,
        bending_um_per_k=COPPER.bending_um_per_k * expansion_per_k / COPPER.expansion_per_k)


#: Pure aluminium (99.99 %; CRC Handbook of Chemistry and Physics): resistivity 2.65e-8 Ohm m at 20 C
#: (37.7 MS/m, 65 % IACS), resistivity tempco 0.0043/K; 237 W/mK (300 K), 2700 kg/m^3, 897 J/kgK, expansion
#: 23.1e-6/K (25 C). Derived: surface lag 35.5 s, gradient 0.017, bending 1.12 um/K.
ALUMINIUM = _like_copper(37.7e6, 0.0043, 237.0, 2700.0, 897.0, 23.1e-6)

#: Brass CuZn37 (C27200, "common brass"; Deutsches Kupferinstitut / ASM data sheets): 15.5 MS/m at 20 C
#: (27 % IACS); resistivity tempco 0.0015/K (handbook tables give brass 0.0015-0.002/K; Matthiessen's rule,
#: copper's phonon slope 6.7e-11 Ohm m/K over brass's 6.45e-8 Ohm m, gives 0.001/K, so the lower table value
#: is taken); 120 W/mK, 8440 kg/m^3, 377 J/kgK; expansion 20e-6/K (data sheets 20.2-20.3e-6 over 20-300 C).
#: Derived: surface lag 92 s, gradient 0.033, bending 0.97 um/K.
BRASS = _like_copper(15.5e6, 0.0015, 120.0, 8440.0, 377.0, 20e-6)

MATERIALS: dict[str, Material] = {"copper": COPPER, "aluminium": ALUMINIUM, "brass": BRASS, "steel": STEEL}


def material_key(name: str) -> str:
    """The name ``MATERIALS`` knows a plate material by (``aluminum`` read as ``aluminium``); an unknown name is
    a ValueError naming it and the known ones."""
    key = _british(name)
    if key not in MATERIALS:
        raise ValueError(f"plate material {name!r} is unknown to the simulated lab; it knows "
                         f"{', '.join(MATERIALS)}")
    return key


def material_named(name: str) -> Material:
    """The plate material ``name`` (``material_key``)."""
    return MATERIALS[material_key(name)]


def _british(name: str) -> str:
    return "aluminium" if name.strip().lower() == "aluminum" else name


class Conductivity(Strict):
    """sigma(T) = sigma20 / (1 + tempco (T - 20 C)); off: the plate keeps its 20 C conductivity."""

    enabled: bool = True
    sigma_20c_s_per_m: float | None = Field(None, gt=0, description="default: copper 58e6, aluminium 37.7e6, "
                                                                    "brass 15.5e6, steel 5e6")
    resistivity_tempco_per_k: float | None = Field(None, description="default: copper 0.0039, aluminium 0.0043, "
                                                                     "brass 0.0015, steel 0.00667")


class Permeability(Strict):
    """mu_r(T) = mu_r20 (1 + tempco (T - 20 C)); off: the plate keeps its 20 C permeability."""

    enabled: bool = True
    mu_r_20c: float | None = Field(None, ge=1, description="default: steel 100, the others 1")
    tempco_per_k: float | None = Field(None, description="default: steel 0.01 (100 -> 200 over 100 K), "
                                                         "the others 0")


class Gradient(Strict):
    """The plate under the winding runs hotter than the thermocouple by ``fraction`` of the plate's rise."""

    enabled: bool = True
    fraction: float | None = Field(None, description="default: copper 0.01, aluminium 0.017, brass 0.033, "
                                                     "steel 0.15")


class Bending(Strict):
    """The hot plate domes toward the coil: centre rise b (T - T_amb), seen edge-weighted (module doc)."""

    enabled: bool = True
    centre_rise_um_per_k: float | None = Field(None, description="default: copper and steel 0.8 um/K, 88 um at "
                                                                 "110 K (sized to paper Fig. 14); aluminium 1.12, "
                                                                 "brass 0.97 (copper's by thermal expansion)")
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
                                                                 "default copper 30 s, aluminium 35.5 s, brass 92 s, "
                                                                 "steel 180 s")

    @field_validator("material", mode="before")
    @classmethod
    def _us_spelling(cls, value: Any) -> Any:
        """``aluminum`` (US) names the same metal as ``aluminium``."""
        return _british(value) if isinstance(value, str) else value


class Plate:
    """Material laws of one plate, resolved from its settings and material defaults."""

    def __init__(self, settings: PlateSettings, material: str) -> None:
        self.settings, self.material = settings, _british(material)
        m = material_named(material)
        c, p = settings.conductivity, settings.permeability
        self.sigma20 = c.sigma_20c_s_per_m if c.sigma_20c_s_per_m is not None else m.sigma_20c_s_per_m
        self.rho_tempco = (c.resistivity_tempco_per_k if c.resistivity_tempco_per_k is not None
                           else m.resistivity_tempco_per_k) if c.enabled else 0.0
        self.mu20 = p.mu_r_20c if p.mu_r_20c is not None else m.mu_r_20c
        self.mu_tempco = (p.tempco_per_k if p.tempco_per_k is not None else m.mu_r_tempco_per_k) if p.enabled else 0.0
        self.surface_lag_s = settings.surface_lag_s if settings.surface_lag_s is not None else m.surface_lag_s
        g, b = settings.gradient, settings.bending
        self.gradient = (g.fraction if g.fraction is not None else m.gradient_fraction) if g.enabled else 0.0
        #: Centre rise of the bending dome per kelvin of the plate's rise (m/K; 0 when off).
        self.bending_per_k = (b.centre_rise_um_per_k if b.centre_rise_um_per_k is not None
                              else m.bending_um_per_k) * 1e-6 if b.enabled else 0.0

    def conductivity(self, t_c: float) -> float:
        return self.sigma20 / (1.0 + self.rho_tempco * (t_c - 20.0))

    def permeability(self, t_c: float) -> float:
        return self.mu20 * (1.0 + self.mu_tempco * (t_c - 20.0))

    def field_temperature_c(self, t_surface_c: float, ambient_c: float) -> float:
        """Temperature of the plate under the winding, from the thermocouple's surface reading."""
        return t_surface_c + self.gradient * (t_surface_c - ambient_c)

    def bending_shift_m(self, x_m: float, t_c: float, ambient_c: float, mean_radius_m: float) -> float:
        """How much nearer the coil the bent plate effectively is (m, >= 0 when hot)."""
        if not self.bending_per_k:
            return 0.0
        rise = self.bending_per_k * (t_c - ambient_c)
        footprint = (mean_radius_m**2 + x_m**2) / self.settings.bending.half_width_m**2
        return rise * max(0.0, 1.0 - footprint)
