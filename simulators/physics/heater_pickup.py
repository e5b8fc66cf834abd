"""Bridge noise that grows with the heater current: the heater supply's current couples into the measurement.

The heaters draw amperes from the supply through leads that run past the coil and the bridge's test
leads. The supply's ripple (mains harmonics of its rectifier, its pre-regulator's switching) rides on that
current and couples into the bridge's measuring loop, magnetically (mutual inductance of the leads) and
through the shared ground. The bridge's synchronous detection rejects most of it; what passes is an extra,
random error of each reading whose size is proportional to the heater current. It is a voltage picked up
beside the test signal, so relative to |Z| it scales as 1.5 V / test level; it averages down as
1/sqrt(averages), and a slower speed (a longer measuring window) rejects more of it. The two heater outputs'
ripples are independent, so their currents add in quadrature:

    sigma_extra = k(speed) sqrt(I_target^2 + I_box^2) * 1.5 V / level / sqrt(averages),

combined in quadrature with the bridge's own noise (the same random draws, so switching it on changes the
size of the noise, not the stream). Flat in frequency (the pickup is set by the ripple, not the test signal).
"""

from __future__ import annotations

import math

from pydantic import Field, field_validator

from ecds_lab.simulators.physics._settings import Strict


class BridgeHeaterPickup(Strict):
    """The bridge's reading noise grows with the heater current (module doc)."""

    enabled: bool = False
    ppm_per_ampere: dict[str, float] = Field(
        {"fast": 100.0, "medium": 30.0, "slow": 10.0},
        description="1 sigma of |Z| per ampere of heater current, per speed, at 1.5 V (slow 2-30 ppm/A)")

    @field_validator("ppm_per_ampere")
    @classmethod
    def _sizes(cls, value: dict[str, float]) -> dict[str, float]:
        bad = {speed: size for speed, size in value.items() if not 0.0 <= size <= 1000.0}
        if bad:
            raise ValueError(f"pickup per ampere must lie in 0..1000 ppm/A, got {bad}")
        return value


class HeaterPickup:
    """The extra relative noise of one reading for the heater currents flowing now."""

    def __init__(self, settings: BridgeHeaterPickup) -> None:
        self.per_ampere = {speed: size * 1e-6 for speed, size in settings.ppm_per_ampere.items()}

    def relative(self, currents_a: tuple[float, ...], speed: str, voltage_v: float, averages: int) -> float:
        """1 sigma relative to |Z| added by the heater currents (0 when no heater current flows)."""
        current = math.sqrt(sum(i * i for i in currents_a))
        if current == 0.0:
            return 0.0
        try:
            per_ampere = self.per_ampere[speed]
        except KeyError:
            raise ValueError(f"bridge speed {speed!r} has no heater pickup figure "
                             f"(have {sorted(self.per_ampere)})") from None
        return per_ampere * current * 1.5 / voltage_v / math.sqrt(max(1, averages))
