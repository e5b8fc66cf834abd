"""A slow drift of the bridge's gain: every reading is the impedance times (1 + g(t)).

An LCR bridge measures |Z| against internal reference resistors and through gain stages whose values
follow the instrument's internal temperature (precision resistors 5-25 ppm/K). While it warms up, or as
the room warms over a day, the internal temperature moves by a few K over hours, so the gain moves by
tens to a few hundred ppm per hour; the air conditioning's cycles add a slow wander of some tens of ppm
with a correlation time of tens of minutes. Here

    g(t) = rate (t - t0) + w(t),

w an Ornstein-Uhlenbeck process (stationary, rms ``wander_ppm``, correlation time ``wander_time_s``)
drawn from its own random stream, so it is a fixed function of time, the same whenever the lab is read,
and switching it on leaves the bridge's noise draws as they were. The gain scales the whole complex
impedance (|Z| scaled, phase unchanged), at every frequency, with the coil in air or at the target.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict

#: Points of the wander's grid per correlation time (linear interpolation between them).
_POINTS_PER_CORRELATION_TIME = 20
#: Grid points drawn at once when the wander is extended.
_CHUNK = 1024
#: Separates the wander's random stream from the lab's own (same lab seed, different stream).
_STREAM = 23_001


class BridgeGainDrift(Strict):
    """The bridge's gain drifts: a linear rate plus a slow random wander (module doc)."""

    enabled: bool = False
    ppm_per_hour: float = Field(50.0, ge=-1000.0, le=1000.0,
                                description="linear gain drift (warm-up or room drift: tens to hundreds of ppm/h)")
    wander_ppm: float = Field(20.0, ge=0.0, le=500.0, description="rms of the slow random wander")
    wander_time_s: float = Field(1800.0, gt=0.0, description="correlation time of the wander")


class GainDrift:
    """g(t) of one lab: the linear rate and the wander, drawn lazily on a grid as time goes on."""

    def __init__(self, settings: BridgeGainDrift, seed: int | None, start_s: float) -> None:
        self.rate_per_s = settings.ppm_per_hour * 1e-6 / 3600.0
        self.start_s = start_s
        self.sigma = settings.wander_ppm * 1e-6
        self.step_s = settings.wander_time_s / _POINTS_PER_CORRELATION_TIME
        self.decay = math.exp(-1.0 / _POINTS_PER_CORRELATION_TIME)
        self._rng = np.random.default_rng([_STREAM, seed or 0])
        # The stationary process starts in its stationary distribution.
        self._grid = np.array([self.sigma * float(self._rng.standard_normal())])

    def gain(self, now_s: float) -> float:
        """1 + g(now): the factor the bridge's reading carries at this time."""
        elapsed = max(0.0, now_s - self.start_s)
        return 1.0 + self.rate_per_s * elapsed + self.wander(elapsed)

    def wander(self, elapsed_s: float) -> float:
        if self.sigma == 0.0:
            return 0.0
        position = elapsed_s / self.step_s
        index = int(position)
        while index + 1 >= self._grid.size:
            self._extend()
        fraction = position - index
        return float(self._grid[index] * (1.0 - fraction) + self._grid[index + 1] * fraction)

    def _extend(self) -> None:
        """Exact OU steps: w_{k+1} = w_k e^{-dt/T} + sigma sqrt(1 - e^{-2 dt/T}) z_k."""
        kicks = (self._rng.standard_normal(_CHUNK) * (self.sigma * math.sqrt(1.0 - self.decay**2))).tolist()
        values, last = [], float(self._grid[-1])
        for kick in kicks:  # a first-order recursion (scipy.signal.lfilter would cost seconds of import)
            last = last * self.decay + kick
            values.append(last)
        self._grid = np.concatenate([self._grid, values])
