"""The sensing coil: winding geometry on its former, the wire's resistance, L in air.

The winding's radii and height scale with the former's linear strain (thermal expansion plus the
swelling of a moist porous former), so L in air scales as L_air(s) = s L_air (Dodd & Deeds self term,
``field_solution``) and the coupling to the plate changes with it. The wire's resistance follows
copper's temperature coefficient, 3900 ppm/K (paper Sec. 2.1), at the winding's temperature.
"""

from __future__ import annotations

import math

from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict
from ecds_lab.simulators.physics.field_solution import Winding

#: Resistivity of annealed copper at 20 C (Ohm m, IEC 60028).
COPPER_RESISTIVITY_OHM_M = 1.724e-8


class WireResistance(Strict):
    """Resistance of the winding's wire: R = R20 (1 + tempco (T_winding - 20 C))."""

    enabled: bool = Field(True, description="off: the wire keeps its 20 C resistance")
    resistance_ohm: float | None = Field(None, gt=0, description="at 20 C; default from the wire's length and "
                                                                  "diameter (about 50 Ohm for the paper's coil)")
    tempco_per_k: float = Field(3900e-6, description="paper Sec. 2.1: copper wire 3900 ppm/K")


class CoilSettings(Strict):
    """The paper's prototype winding (Sec. 2.2): 500 turns of 0.3 mm wire, 110-150 mm diameter, 3 mm high."""

    inner_radius_m: float = Field(0.055, gt=0)
    outer_radius_m: float = Field(0.075, gt=0)
    height_m: float = Field(0.003, gt=0)
    turns: int = Field(500, gt=0)
    wire_diameter_m: float = Field(0.3e-3, gt=0)
    wire_resistance: WireResistance = WireResistance()

    def winding(self) -> Winding:
        return Winding(self.inner_radius_m, self.outer_radius_m, self.height_m, self.turns)

    def resistance_20c_ohm(self) -> float:
        """R at 20 C: the configured value, else rho L / A for N turns at the mean radius."""
        if self.wire_resistance.resistance_ohm is not None:
            return self.wire_resistance.resistance_ohm
        length = self.turns * math.pi * (self.inner_radius_m + self.outer_radius_m)
        return COPPER_RESISTIVITY_OHM_M * length / (math.pi * self.wire_diameter_m**2 / 4)

    def resistance_ohm(self, t_winding_c: float) -> float:
        r20 = self.resistance_20c_ohm()
        if not self.wire_resistance.enabled:
            return r20
        return r20 * (1.0 + self.wire_resistance.tempco_per_k * (t_winding_c - 20.0))
