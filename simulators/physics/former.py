"""The coil former: thermal expansion, moisture, and the parallel capacitance and loss they set.

Expansion: the former's linear strain at the winding, eps = a_exp (T - 20 C) + swelling m_s, scales
the winding (gypsum 25e-6/K, fired clay 7.5e-6/K: paper Sec. 4.2; plastic ~70e-6/K).

Moisture (paper Sec. 4.2, Table 2): a porous former holds water in two pools, the clay around the
winding's groove (m_s, sets the extra inter-winding capacitance and some loss) and the bulk (m_b,
loss only). Each relaxes toward the equilibrium moisture at its temperature,

    m_eq(T) = exp(-(T - T_ambient) / T_scale),   dm/dt = (m_eq - m) / tau,

with tau = tau_dry(T) = tau_dry(100 C) 2^((100 C - T) / doubling) while drying (faster when hot)
and the slow re-absorption time at room temperature otherwise. Then

    C_p = C_dry + dC m_s,   G_p = (1/R_dry + g_s m_s + g_b m_b) f / f_ref.

The loss is dielectric (a constant loss tangent of the former's capacitance), so its conductance grows
in proportion to frequency; the conductances are given at f_ref = 85 kHz, near the coil's self-resonance
where Table 2's parallel RLC fits measure R_p. At 500 Hz the loss is then negligible for L.

Sizes from Table 2: moist 62.5 pF / 92 kOhm at 20 C, 47.46 pF / 212 kOhm at 65 C (the groove is dry,
the bulk still partly moist), 47.53 pF / 984 kOhm at 120 C (dry). Drying also shrinks the former:
the swelling strain of the moist groove clay gives the paper's initial fall of L at 500 Hz (Fig. 19).
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict
from ecds_lab.simulators.physics.humidity_uptake import HumidityUptake

FormerMaterial = Literal["gypsum", "fired_clay", "plastic"]

#: Linear thermal expansion (1/K): paper Sec. 4.2 (gypsum, fired clay); plastic (PA/POM) typical.
EXPANSION_PER_K: dict[str, float] = {"gypsum": 25e-6, "fired_clay": 7.5e-6, "plastic": 70e-6}


class Expansion(Strict):
    """Thermal expansion of the former, which scales the winding."""

    enabled: bool = True
    per_k: float | None = Field(None, description="default: the former material's (gypsum 25e-6, fired clay 7.5e-6)")


class Moisture(Strict):
    """Water held by a porous former: extra parallel capacitance and loss, and swelling (Table 2)."""

    enabled: bool = True
    initial: float = Field(1.0, ge=0, le=1, description="start moisture of both pools (1: stored in the lab)")
    dry_capacitance_f: float = Field(47.5e-12, ge=0, description="Table 2, 65 and 120 C")
    moist_extra_capacitance_f: float = Field(15.0e-12, ge=0, description="Table 2: 62.5 pF moist at 20 C")
    dry_parallel_resistance_ohm: float = Field(984e3, gt=0, description="Table 2, 120 C")
    groove_conductance_s: float = Field(1.85e-6, ge=0, description="loss of the moist groove clay")
    bulk_conductance_s: float = Field(8.0e-6, ge=0, description="loss of the moist bulk; sum: 92 kOhm at 20 C")
    groove_scale_k: float = Field(8.0, gt=0, description="equilibrium moisture e^{-(T - T_amb)/scale}")
    bulk_scale_k: float = Field(30.0, gt=0)
    groove_drying_tau_at_100c_s: float = Field(60.0, gt=0)
    bulk_drying_tau_at_100c_s: float = Field(300.0, gt=0)
    drying_doubling_k: float = Field(12.0, gt=0, description="drying twice as fast every this many kelvin")
    reabsorption_tau_s: float = Field(3 * 24 * 3600.0, gt=0, description="slow re-absorption at room temperature")
    swelling_strain: float = Field(150e-6, ge=0, description="linear strain of the fully moist groove clay")
    loss_reference_hz: float = Field(85e3, gt=0, description="frequency at which the conductances are given "
                                                              "(dielectric loss: G grows with f)")


class FormerSettings(Strict):
    """The coil former: material, thermal expansion, moisture."""

    material: FormerMaterial | None = Field(None, description="default: the sensor description's former")
    expansion: Expansion = Expansion()
    moisture: Moisture = Moisture()


class FormerState:
    """Moisture of the groove and bulk pools, integrated exactly over constant-temperature steps.

    The settings are resolved into plain attributes once, as ``Plate`` does: every reading reads about twenty
    of them, and a pydantic model's field costs several times a plain attribute.
    """

    def __init__(self, settings: FormerSettings, material: str, ambient_c: float,
                 uptake: HumidityUptake | None = None) -> None:
        """``uptake``: the room air's re-absorption (``humidity_uptake``) in place of the slow room-temperature one."""
        self.settings, self.material, self.ambient_c = settings, material, ambient_c
        self.uptake = uptake
        e, wet = settings.expansion, settings.moisture
        self.expansion_per_k = (e.per_k if e.per_k is not None else EXPANSION_PER_K[material]) if e.enabled else 0.0
        self.moist = wet.enabled
        self.groove_scale_k, self.groove_drying_tau_s = wet.groove_scale_k, wet.groove_drying_tau_at_100c_s
        self.bulk_scale_k, self.bulk_drying_tau_s = wet.bulk_scale_k, wet.bulk_drying_tau_at_100c_s
        self.drying_doubling_k, self.reabsorption_tau_s = wet.drying_doubling_k, wet.reabsorption_tau_s
        self.swelling_strain = wet.swelling_strain
        self.dry_capacitance_f, self.moist_extra_capacitance_f = wet.dry_capacitance_f, wet.moist_extra_capacitance_f
        self.dry_conductance_s = 1.0 / wet.dry_parallel_resistance_ohm
        self.groove_conductance_s, self.bulk_conductance_s = wet.groove_conductance_s, wet.bulk_conductance_s
        self.loss_reference_hz = wet.loss_reference_hz
        start = wet.initial if wet.enabled else 0.0
        self.groove, self.bulk = start, start
        self._equilibria_at_c = math.nan  # the temperature the pools' equilibria below were worked out for
        self._equilibria = (1.0, 1.0)
        self._uptake_taus = (self.reabsorption_tau_s, self.reabsorption_tau_s)  # (groove, bulk) at that temperature

    def step(self, t_former_c: float, dt_s: float) -> None:
        if not self.moist:
            return
        if t_former_c != self._equilibria_at_c:  # the equilibria change only with the temperature (ambient is fixed)
            self._equilibria = (self._equilibrium(t_former_c, self.groove_scale_k),
                                self._equilibrium(t_former_c, self.bulk_scale_k))
            if self.uptake is not None:
                self._uptake_taus = self.uptake.taus_s(t_former_c)
            self._equilibria_at_c = t_former_c
        groove_equilibrium, bulk_equilibrium = self._equilibria
        # A pool at its equilibrium stays there (relaxing would give exactly the same value).
        if self.groove != groove_equilibrium:
            self.groove = self._relax(self.groove, groove_equilibrium, t_former_c, dt_s, self.groove_drying_tau_s,
                                      self._uptake_taus[0])
        if self.bulk != bulk_equilibrium:
            self.bulk = self._relax(self.bulk, bulk_equilibrium, t_former_c, dt_s, self.bulk_drying_tau_s,
                                    self._uptake_taus[1])

    def _equilibrium(self, t_c: float, scale_k: float) -> float:
        return min(1.0, math.exp(-(t_c - self.ambient_c) / scale_k))

    def _relax(self, m: float, equilibrium: float, t_c: float, dt_s: float, tau100_s: float, uptake_s: float) -> float:
        if m > equilibrium:
            tau = tau100_s * 2.0 ** ((100.0 - t_c) / self.drying_doubling_k)
        else:
            tau = uptake_s
        return equilibrium + (m - equilibrium) * math.exp(-dt_s / tau)

    def strain(self, t_winding_c: float) -> float:
        """Linear strain of the former at the winding relative to a dry former at 20 C, its thermal part at
        ``t_winding_c`` (the winding's temperature, or the one a hysteresis of the expansion holds it at)."""
        swelling = self.swelling_strain * self.groove if self.moist else 0.0
        return self.expansion_per_k * (t_winding_c - 20.0) + swelling

    def parallel_elements(self, frequency_hz: float) -> tuple[float, float]:
        """(C_p in F, G_p in S) of the former across the winding now, at the bridge's frequency."""
        c = self.dry_capacitance_f
        g = self.dry_conductance_s
        if self.moist:
            c += self.moist_extra_capacitance_f * self.groove
            g += self.groove_conductance_s * self.groove + self.bulk_conductance_s * self.bulk
        return c, g * frequency_hz / self.loss_reference_hz
