"""Glitch readings: single readings far from their neighbours, excluded from the fit with the reason.

A reading is a glitch when it stands far out (``THRESHOLD`` noise sigmas) from the running median
of the residual along its series of like readings (``noise.smooth_residual``), and readings of
the same state elsewhere in the campaign (same frequency and commanded distance) do not share
the deviation: a deviation that repeats is structure an effect may explain, never a glitch.
The running median repeats the end values of a run, so the two readings at either end of a run
(a sweep's turning points) are not judged: a peak of the residual there is structure as often as not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ecds_lab.analysis.noise import smooth_residual
from ecds_lab.data.measurements import Measurements

#: Deviation from the local smooth, in noise sigmas, that marks a glitch (about one false flag in
#: 10^6 readings of Gaussian noise).
THRESHOLD = 5.5
#: Readings of the same state deviating alike (by this many sigmas, median) make it structure.
REPEATED = 3.0


@dataclass(frozen=True)
class Outlier:
    """A reading left out of the fit: its row (0-based, in the order of the data), the reading (H),
    its deviation in noise units and why."""

    row: int
    value: float
    residual_sigma: float
    reason: str

    def to_json(self) -> dict[str, object]:
        return {"row": self.row, "value": self.value, "residual_sigma": round(self.residual_sigma, 1),
                "reason": self.reason}


def find_glitches(data: Measurements, residuals_ppm: np.ndarray, noise_ppm: float) -> np.ndarray:
    """Boolean mask of glitch readings (see the module docstring), and their deviation in sigmas."""
    r = np.asarray(residuals_ppm, float)
    if not len(r) or not noise_ppm > 0:
        return np.zeros(len(r), bool)
    deviation = (r - smooth_residual(data, r)) / noise_ppm
    suspect = np.abs(deviation) > THRESHOLD
    for i in np.flatnonzero(suspect):
        same = ((data.freq_hz == data.freq_hz[i]) & (data.direction == data.direction[i])
                & ((data.x_commanded_m == data.x_commanded_m[i])
                   | (np.isinf(data.x_commanded_m) & np.isinf(data.x_commanded_m[i]))))
        same[i] = False
        others = deviation[same & ~suspect]
        if len(others) and np.sign(np.median(others)) == np.sign(deviation[i]) and \
                abs(np.median(others)) > REPEATED:
            suspect[i] = False
    return suspect


def describe(data: Measurements, rows: np.ndarray, residuals_ppm: np.ndarray, noise_ppm: float,
             index: np.ndarray) -> list[Outlier]:
    """Outlier records for ``rows`` (indices into ``data``), numbered by ``index`` (original rows)."""
    deviation = (residuals_ppm - smooth_residual(data, residuals_ppm)) / noise_ppm
    out = []
    for i in rows:
        where = "coil in air" if not np.isfinite(data.x_m[i]) else f"x = {data.x_m[i] * 1e3:.4g} mm"
        out.append(Outlier(int(index[i]), float(data.ls_h[i]), float(deviation[i]),
                           f"glitch: {deviation[i]:+.1f} sigma from its neighbours ({where}, "
                           f"{data.freq_hz[i]:g} Hz, t = {data.time_s[i]:.0f} s), not repeated by "
                           f"readings of the same state; excluded from the fit"))
    return out
