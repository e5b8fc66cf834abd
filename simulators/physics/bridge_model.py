"""What the LCR bridge adds to the true impedance: noise, basic accuracy, rare glitches.

HM8118 (Hameg/R&S manual): basic accuracy 0.05 %, measuring speeds fast/medium/slow, slow the most
accurate (the paper used slow at 1.5 V). The manual specifies accuracy, not noise; the noise here is
an assumption sized to the paper's smooth curves: relative noise per speed at 1 kHz and 1.5 V, rising
as 1/sqrt(f) below 1 kHz (fewer signal periods in the measuring window) and in proportion to f above
100 kHz, falling with the test level and the square root of the averages.
Basic accuracy: each (frequency, range) has a fixed gain and phase error, drawn once per lab within
``realised_fraction`` of the specification. Glitches: with a small probability a reading is wrong by
a few percent, as real bridges now and then report when a range switch or interference hits.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict


class BridgeNoise(Strict):
    enabled: bool = True
    relative_at_1khz: dict[str, float] = Field({"fast": 200e-6, "medium": 60e-6, "slow": 15e-6},
                                               description="1 sigma of |Z|, per speed, at 1 kHz and 1.5 V")


class BasicAccuracy(Strict):
    enabled: bool = True
    relative: float = Field(5e-4, ge=0, description="HM8118 basic accuracy 0.05 %")
    realised_fraction: float = Field(0.1, ge=0, le=1, description="how much of the specification one "
                                                                   "instrument's error uses")


class Glitches(Strict):
    enabled: bool = True
    rate_per_reading: float = Field(5e-4, ge=0, le=1)
    size_relative: float = Field(0.02, ge=0, description="typical size of a glitch (relative to |Z|)")


class BridgeModelSettings(Strict):
    """The bridge's imperfections (physics: field)."""

    noise: BridgeNoise = BridgeNoise()
    accuracy: BasicAccuracy = BasicAccuracy()
    glitches: Glitches = Glitches()


def _range(magnitude_ohm: float) -> int:
    """The bridge's impedance range for |Z| (decades from 100 Ohm)."""
    return math.floor(math.log10(max(magnitude_ohm, 1.0) / 100.0))


class BridgeModel:
    """Turns the true impedance into a reading."""

    def __init__(self, settings: BridgeModelSettings, seed: int | None) -> None:
        self.settings = settings
        self._seed = seed
        # Read on every reading: resolved once into plain attributes (a pydantic field costs several times as much).
        g = settings.glitches
        self._accurate = settings.accuracy.enabled
        self._glitch_rate = g.rate_per_reading if g.enabled else 0.0
        self._glitch_size = g.size_relative
        self._errors: dict[tuple[float, int], complex] = {}
        self._noise: dict[tuple[float, str, float, int], float] = {}

    def noise_relative(self, frequency_hz: float, speed: str, voltage_v: float, averages: int) -> float:
        """Relative noise (1 sigma) of one reading; a pure function of the settings and the arguments, so it is
        remembered per arguments (a run asks the same few combinations for every reading)."""
        key = (frequency_hz, speed, voltage_v, averages)
        sigma = self._noise.get(key)
        if sigma is None:
            sigma = self._noise[key] = self._noise_relative(frequency_hz, speed, voltage_v, averages)
        return sigma

    def _noise_relative(self, frequency_hz: float, speed: str, voltage_v: float, averages: int) -> float:
        n = self.settings.noise
        if not n.enabled:
            return 0.0
        try:
            base = n.relative_at_1khz[speed]
        except KeyError:
            raise ValueError(f"bridge speed {speed!r} has no noise figure "
                             f"(have {sorted(n.relative_at_1khz)})") from None
        shape = math.sqrt(1000.0 / frequency_hz) if frequency_hz < 1000.0 else max(1.0, frequency_hz / 100e3)
        return base * shape * 1.5 / voltage_v / math.sqrt(max(1, averages))

    def _systematic(self, frequency_hz: float, z: complex) -> complex:
        """(1 + gain error) e^{j phase error} of this instrument at this frequency and range."""
        key = (frequency_hz, _range(abs(z)))
        error = self._errors.get(key)
        if error is None:
            acc = self.settings.accuracy
            spread = acc.relative * acc.realised_fraction
            rng = np.random.default_rng([abs(hash(key)) % (2**32), self._seed or 0])
            gain, phase = rng.uniform(-spread, spread, 2).tolist()  # Python floats: no numpy scalars downstream
            error = self._errors[key] = (1.0 + gain) * complex(math.cos(phase), math.sin(phase))
        return error

    def read(self, z: complex, frequency_hz: float, speed: str, voltage_v: float, averages: int,
             rng: np.random.Generator, extra_relative: float = 0.0) -> complex:
        """The reading of the true impedance ``z``; ``extra_relative``: noise from outside the bridge (1 sigma
        relative to |Z|), added in quadrature to its own."""
        if self._accurate:
            z = z * self._systematic(frequency_hz, z)
        sigma = self.noise_relative(frequency_hz, speed, voltage_v, averages)
        if extra_relative:
            sigma = math.hypot(sigma, extra_relative)
        if sigma > 0:
            real, imag = rng.standard_normal(2).tolist()
            z = z + abs(z) * sigma * complex(real, imag)
        rate = self._glitch_rate
        if rate > 0 and rng.random() < rate:
            z = z * (1.0 + self._glitch_size * float(rng.choice((-1.0, 1.0))) * (0.5 + rng.random()))
        return z
