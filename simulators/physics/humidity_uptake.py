"""Re-absorption of humidity while cooling: a dried former takes water up again from the room's air.

A porous former dried by heating adsorbs water vapour from the air again as it cools. The uptake is driven
by the relative humidity at its surface: the air there carries the room's vapour pressure but is at the
former's temperature, so

    RH_surface(T) = RH_room * p_sat(T_ambient) / p_sat(T)

(p_sat from the Magnus formula, WMO-No. 8: 6.112 hPa exp(17.62 T / (243.12 C + T))). A warm former sees dry
air and takes up little; as it cools the uptake quickens. Each moisture pool relaxes toward its equilibrium
at the time constant

    tau_up(T) = tau_pool * 0.5 / RH_surface(T),

tau_pool the pool's uptake time at room temperature and 50 % RH: the groove clay (open to the air) in tens of
minutes to hours, the bulk slower. This replaces the former's slow room-temperature re-absorption (3 days)
while the former is below its equilibrium moisture; drying is unchanged. With 50 % RH at 22 C a former at
40 C sees 18 % (uptake 2.8 times slower than when cool), at 80 C 2.8 % (18 times slower).
"""

from __future__ import annotations

import math

from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict

#: Magnus formula over water (WMO-No. 8, Annex 4.B): p_sat = 6.112 hPa exp(A T / (B + T)), T in C.
_MAGNUS_A, _MAGNUS_B_C = 17.62, 243.12
#: Relative humidity at which the pools' uptake times are given.
REFERENCE_HUMIDITY = 0.5


class Reabsorption(Strict):
    """The cooling former re-absorbs water from the room's air, at a rate its surface humidity sets."""

    enabled: bool = False
    relative_humidity: float = Field(0.5, gt=0.0, le=1.0, description="the room's relative humidity (0.2-0.8)")
    groove_uptake_tau_s: float = Field(3600.0, ge=60.0, le=7 * 24 * 3600.0,
                                       description="uptake time of the groove clay at room temperature and 50 % "
                                                   "RH (20 min - 4 h)")
    bulk_uptake_tau_s: float = Field(4 * 3600.0, ge=60.0, le=7 * 24 * 3600.0,
                                     description="uptake time of the bulk at room temperature and 50 % RH "
                                                 "(1 - 24 h)")


def saturation_pressure_ratio(t_c: float, ambient_c: float) -> float:
    """p_sat(t) / p_sat(ambient) by the Magnus formula."""
    return math.exp(_MAGNUS_A * t_c / (_MAGNUS_B_C + t_c) - _MAGNUS_A * ambient_c / (_MAGNUS_B_C + ambient_c))


class HumidityUptake:
    """Uptake time constants of the former's two pools at a temperature."""

    def __init__(self, settings: Reabsorption, ambient_c: float) -> None:
        self.humidity = settings.relative_humidity
        self.groove_tau_s = settings.groove_uptake_tau_s
        self.bulk_tau_s = settings.bulk_uptake_tau_s
        self.ambient_c = ambient_c

    def surface_humidity(self, t_c: float) -> float:
        """Relative humidity of the air at a surface at ``t_c`` (capped at saturation)."""
        return min(1.0, self.humidity / saturation_pressure_ratio(t_c, self.ambient_c))

    def taus_s(self, t_c: float) -> tuple[float, float]:
        """(groove, bulk) uptake time constants at a former temperature."""
        factor = REFERENCE_HUMIDITY / self.surface_humidity(t_c)
        return self.groove_tau_s * factor, self.bulk_tau_s * factor
