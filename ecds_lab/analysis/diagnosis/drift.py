"""Could a claim be a part of a slow drift in time? The one imperfection every instrument has is a slow drift
(a bridge's gain that creeps with the hours): it moves every reading alike, in air or at the target, at every
frequency, and it goes on smoothly across the changes of state a campaign makes. An effect tied to a state (a
bending while the target is hot) acts only on the readings of that state.

So the drift is read where the claim does not act (its readings outside the claim's signature: in air, cold,
another phase), smoothed (``SMOOTH_READINGS``-reading running median in time), and carried by linear interpolation
in time to the readings where it acts. A claim that keeps less than a share of its gain once that drift is taken
out of the residual, with and without it, took a part of the drift: a bending fitted to the offset of one hot sweep
that the readings in air before and after it show as well.
"""

from __future__ import annotations

import numpy as np

from ecds_lab.analysis.noise import running_median
from ecds_lab.data.measurements import Measurements

#: Readings of the running median that smooths the residual outside the claim's signature.
SMOOTH_READINGS = 5
#: The drift is read only from at least this many readings outside the signature, some before and some after it
#: in time (else it would be extrapolated, not read).
MIN_READINGS = 2 * SMOOTH_READINGS


def drift_read_outside(data: Measurements, residual: np.ndarray, acts: np.ndarray) -> np.ndarray | None:
    """The residual's slow course in time read from the readings outside ``acts`` (a boolean mask) and carried to
    every reading; None when too few readings lie outside it, or none before or none after the readings in it."""
    outside = np.flatnonzero(~acts)
    inside_t = data.time_s[acts]
    if len(outside) < MIN_READINGS or not len(inside_t):
        return None
    t_out = data.time_s[outside]
    if not (t_out.min() < inside_t.min() and t_out.max() > inside_t.max()):
        return None
    order = np.argsort(t_out, kind="stable")
    smooth = running_median(np.asarray(residual, float)[outside][order], SMOOTH_READINGS)
    return np.interp(data.time_s, t_out[order], smooth)


def gain_beside_drift(data: Measurements, before: np.ndarray, after: np.ndarray, acts: np.ndarray) -> float | None:
    """What a claim gains (sum of squares of the weighed residual, ``before`` minus ``after`` the claim) once the
    drift read outside its signature ``acts`` is taken out of both; None when the drift cannot be read there."""
    drift = drift_read_outside(data, before, acts)
    if drift is None:
        return None
    rest_before, rest_after = before - drift, after - drift
    return float(rest_before @ rest_before - rest_after @ rest_after)
