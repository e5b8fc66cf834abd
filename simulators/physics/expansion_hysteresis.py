"""A hysteresis of the former's expansion: the winding follows the former by friction, with a dead band.

The winding is held on its former by friction (and the varnish between turns and groove). As the former
expands or contracts with temperature, the winding is dragged along only once the shear between them
exceeds static friction; until then it stays put, and what it lost is not recovered on the way back
(stick-slip, a rigid-plastic joint). In temperature this is a play (backlash) operator: the temperature
that sets the winding's thermal strain, T_p, follows the winding's temperature T only when it is more
than half the width away,

    T_p <- min(max(T_p, T - w/2), T + w/2),

so heating runs w/2 below T and cooling w/2 above it: at one temperature the strain differs between
heating and cooling by alpha_exp * w, and after a heating cycle the winding keeps alpha_exp * w/2 of it at
room temperature. Field physics: the former's thermal strain is alpha_exp (T_p - 20 C); ECM physics: the
alpha term of L_coil follows T_p. T_p starts at ambient, centred in the band. Sizes: a winding friction
equivalent to 1-10 K of differential expansion; 4 K gives 30 ppm of strain between the branches on fired
clay (7.5e-6/K), 100 ppm on gypsum (25e-6/K).
"""

from __future__ import annotations

from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict


class ExpansionHysteresis(Strict):
    """The winding follows the former's expansion through a dead band of ``width_k`` (module doc)."""

    enabled: bool = False
    width_k: float = Field(4.0, gt=0.0, le=30.0, description="full width of the dead band in winding temperature "
                                                             "(1-10 K)")


class ExpansionPlay:
    """The play operator's state: the temperature that sets the winding's thermal strain."""

    def __init__(self, settings: ExpansionHysteresis, start_c: float) -> None:
        self.half_width_k = 0.5 * settings.width_k
        self.temperature_c = start_c

    def follow(self, t_winding_c: float) -> None:
        """Move the strain's temperature just as far as the band requires for the winding at ``t_winding_c``."""
        low, high = t_winding_c - self.half_width_k, t_winding_c + self.half_width_k
        if self.temperature_c < low:
            self.temperature_c = low
        elif self.temperature_c > high:
            self.temperature_c = high
