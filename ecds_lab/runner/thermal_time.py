"""How long a heating wait and a cool-down take in lab time, from the station's thermal time constants and the
steady-state criterion the run waits on: the plan's estimate (``--dry-run``, the ETA before calibration).

A heated part approaches its setpoint with its remaining error falling by e every ``settling_time_constant_s``
(the station's declared figure, ``thermal:`` in the station YAML). The wait ends once the error is within
the tolerance *and* its rate (error / time constant) below the criterion's slope, and the criterion's window
has then been seen: ``window + tau * ln(step / allowed error)``. Free cooling falls towards ambient with
``cooling_time_constant_s``. Both are first-order pictures: the run's own finished waits calibrate the rest
(runner/progress.py), so a lab that is not first order is still estimated well once its first wait is done.
"""

from __future__ import annotations

import math

from ecds_lab.config.station import HeatedPart
from ecds_lab.runner.steady_state import SteadyState


def heating_wait_s(steady: SteadyState, step_k: float, part: HeatedPart) -> float:
    """Lab seconds from setting a new setpoint ``step_k`` away until ``steady`` holds (capped by its timeout)."""
    tau = part.settling_time_constant_s
    allowed_k = min(steady.tolerance_k, steady.slope_k_per_min / 60.0 * tau)
    settle = tau * math.log(abs(step_k) / allowed_k) if abs(step_k) > allowed_k else 0.0
    seconds = steady.window_s + settle
    return min(seconds, steady.timeout_s) if steady.timeout_s is not None else seconds


def cooling_s(from_c: float, below_c: float, ambient_c: float, part: HeatedPart, timeout_s: float | None) -> float:
    """Lab seconds of free cooling from ``from_c`` to ``below_c`` towards ``ambient_c`` (the timeout when it
    never gets there: ``below_c`` at or under ambient)."""
    if from_c <= below_c:
        return 0.0
    if below_c <= ambient_c:
        return timeout_s if timeout_s is not None else math.inf
    seconds = part.cooling_time_constant_s * math.log((from_c - ambient_c) / (below_c - ambient_c))
    return min(seconds, timeout_s) if timeout_s is not None else seconds
