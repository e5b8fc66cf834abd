"""slide_backlash: the position reached depends on the direction of approach.

Lead-screw play leaves the carriage short of the commanded position by half the backlash,
on the side it came from: x_eff = x - direction * b / 2 (direction +1 increasing x, -1 decreasing).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import Effect, register
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import Tangent, plus


@register
class SlideBacklash(Effect):
    name = "slide_backlash"
    explains = "the slide stops short by half its backlash, on the side it approached from"
    #: A lead screw's play: up to a few hundred micrometres (PHYSICS.md: accuracy tens of um).
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"backlash": (-500e-6, 500e-6)}
    reveal = "approach every position from both directions (a forward and a backward sweep)"
    reveal_needs: ClassVar[dict[str, float]] = {"directions": 2}

    def parameters(self) -> list[Parameter]:
        return [Parameter("backlash", 0.0, -1e-3, 1e-3, "m", "slide backlash (play between directions)", 2e-5)]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        directions = set(np.unique(data.direction[np.isfinite(data.x_m)]).tolist()) - {0}
        return {} if directions == {-1, 1} else {"backlash": "the data approach from one direction only"}

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        return x_m - data.direction * p["backlash"] / 2

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self.effective_distance(x_m, data, p), plus(dx, {"backlash": -0.5 * data.direction})
