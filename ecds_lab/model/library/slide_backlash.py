"""slide_backlash: the position reached depends on the direction of approach.

Lead-screw play leaves the carriage short of the commanded position by half the backlash,
on the side it came from: x_eff = x - direction * b / 2 (direction +1 increasing x, -1 decreasing).

It shows as the difference between the same position approached from both sides under the same conditions; with
the calibration taking any offset shared by every reading, that difference is all that tells it. So it is tested
only where ``MIN_PAIRED_POSITIONS`` positions were each approached from both sides at the same coil and target
temperatures (in the same ``SAME_TEMPERATURE_K`` bin): a slide sweeping up that comes down only to start a hot
run has its two sides at different temperatures, and whatever the heat does there (a plate bending nearer) would
be read as play.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import Effect, register
from ecds_lab.model.library.remembered import Remembered
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import Tangent, plus

#: Positions a backlash needs approached from both sides at the same temperatures: one such pair differs by
#: whatever else differs between its two visits, two show an offset that follows the direction.
MIN_PAIRED_POSITIONS = 2
#: Coil and target temperatures within the same bin of this width (K) count as the same conditions.
SAME_TEMPERATURE_K = 2.0


@register
class SlideBacklash(Effect):
    name = "slide_backlash"
    explains = "the slide stops short by half its backlash, on the side it approached from"
    #: A lead screw's play: up to a few hundred micrometres (PHYSICS.md: accuracy tens of um).
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"backlash": (-500e-6, 500e-6)}
    reveal = "approach every position from both directions (a forward and a backward sweep)"
    reveal_needs: ClassVar[dict[str, float]] = {"directions": 2}
    #: Sweeps up then down leave a drift between them as a difference between the directions (a bridge's gain
    #: creeping by 214 ppm an hour over a 7-minute campaign was claimed as 2.9 um of play, validation study seed
    #: 2029 case 60): the play must show beside a drift in time.
    drift_leaves_it = True
    reveal_beside_drift = ("sweep up and down twice over (up, down, up, down): a drift between the sweeps grows with "
                           "the time between them, the play between the directions does not")

    def __init__(self, sensor: SensorConfig) -> None:
        super().__init__(sensor)
        self._untestable: Remembered[dict[str, str]] = Remembered()

    def parameters(self) -> list[Parameter]:
        return [Parameter("backlash", 0.0, -1e-3, 1e-3, "m", "slide backlash (play between directions)", 2e-5)]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        # every fit asks: worked out once per data (``_untestable``)
        return dict(self._untestable.get(data, None, lambda: _untestable(data)))

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        return x_m - data.direction * p["backlash"] / 2

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self.effective_distance(x_m, data, p), plus(dx, {"backlash": -0.5 * data.direction})


def _untestable(data: Measurements) -> dict[str, str]:
    """Why these data cannot tell a backlash (``SlideBacklash.unidentifiable``): one direction only, or too few
    positions approached from both sides at the same temperatures."""
    directions = set(np.unique(data.direction[np.isfinite(data.x_m)]).tolist()) - {0}
    if directions != {-1, 1}:
        return {"backlash": "the data approach from one direction only"}
    paired = _paired_positions(data)
    if paired < MIN_PAIRED_POSITIONS:
        return {"backlash": f"{paired} position(s) approached from both directions at the same temperatures "
                            f"(a backlash needs {MIN_PAIRED_POSITIONS}; the two sides differ in temperature elsewhere)"}
    return {}


def _paired_positions(data: Measurements) -> int:
    """How many positions (to 1 um) were approached from both directions with the coil and target temperatures in
    the same ``SAME_TEMPERATURE_K`` bins, on any of the grids of bins shifted by half a bin in either temperature (so
    two approaches within half a bin of each other always share one, wherever the bins' edges fall)."""
    rows = np.isfinite(data.x_m) & (data.direction != 0)
    if not rows.any():
        return 0
    x_um = np.round(data.x_m[rows] * 1e6).astype(np.int64)
    up = (data.direction[rows] > 0).astype(np.int64)
    coil, target = data.t_coil_c[rows] / SAME_TEMPERATURE_K, data.t_target_c[rows] / SAME_TEMPERATURE_K
    paired: set[int] = set()
    for coil_shift in (0.0, 0.5):
        for target_shift in (0.0, 0.5):
            # one integer per (position, coil bin, target bin): 2^20 bins each is beyond any temperature
            place = (x_um << 40) + (np.floor(coil + coil_shift).astype(np.int64) % (1 << 20) << 20) \
                + np.floor(target + target_shift).astype(np.int64) % (1 << 20)
            approaches = np.unique(place * 2 + up)
            places, sides = np.unique(approaches // 2, return_counts=True)
            paired.update((places[sides > 1] >> 40).tolist())
    return len(paired)
