"""The wider world's imperfections of one lab, built from its ``imperfections`` block: each None while off.

Held by the lab as one object, so the lab keeps few attributes of its own (CPython shares an instance's
attribute keys with its class, the fast path for ``self.x``, only up to 30 of them) and a reading pays one
flag check per place the imperfections act, not one per imperfection.
"""

from __future__ import annotations

from dataclasses import dataclass

from ecds_lab.simulators.config import Imperfections
from ecds_lab.simulators.physics.bridge_gain import GainDrift
from ecds_lab.simulators.physics.expansion_hysteresis import ExpansionPlay
from ecds_lab.simulators.physics.field_solution import Winding
from ecds_lab.simulators.physics.heater_pickup import HeaterPickup
from ecds_lab.simulators.physics.humidity_uptake import HumidityUptake
from ecds_lab.simulators.physics.metal_object import MetalObjectNearby
from ecds_lab.simulators.physics.target_tilt import Tilt


@dataclass(frozen=True, slots=True)
class WiderWorld:
    """The imperfections switched on (None: off) and, per place they act, whether any does."""

    gain_drift: GainDrift | None = None
    pickup: HeaterPickup | None = None
    metal: MetalObjectNearby | None = None
    tilt: Tilt | None = None
    play: ExpansionPlay | None = None
    uptake: HumidityUptake | None = None

    @property
    def at_the_bridge(self) -> bool:
        """Whether anything acts on the bridge's reading (gain drift, heater pickup)."""
        return self.gain_drift is not None or self.pickup is not None

    @property
    def beyond_the_memo_key(self) -> bool:
        """Whether the field impedance depends on state its memo key does not hold (carriage place, play)."""
        return self.metal is not None or self.play is not None

    @classmethod
    def of(cls, wider: Imperfections, winding: Winding, ambient_c: float, seed: int | None,
           start_s: float) -> WiderWorld:
        """The imperfections the settings switch on (the gain drift's time counted from ``start_s``)."""
        return cls(
            gain_drift=GainDrift(wider.bridge_gain_drift, seed, start_s) if wider.bridge_gain_drift.enabled else None,
            pickup=HeaterPickup(wider.bridge_heater_pickup) if wider.bridge_heater_pickup.enabled else None,
            metal=MetalObjectNearby(wider.metal_object, winding) if wider.metal_object.enabled else None,
            tilt=(Tilt(wider.target_tilt, 0.5 * (winding.inner_radius_m + winding.outer_radius_m), ambient_c)
                  if wider.target_tilt.enabled else None),
            play=ExpansionPlay(wider.expansion_hysteresis, ambient_c) if wider.expansion_hysteresis.enabled else None,
            uptake=HumidityUptake(wider.reabsorption, ambient_c) if wider.reabsorption.enabled else None,
        )
