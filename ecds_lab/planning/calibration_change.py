"""What a smooth change of a new run's calibration can absorb: the nuisance a separation must survive.

T-optimal design supposes the rival models are right. A lab is not: between runs and within one, the bridge's gain
and the cables drift with the room, and a target set up again sits at a slightly other distance. Such a change is
smooth: per frequency, an offset and a drift linear in time over the run, and in a sweep a change linear and
quadratic in distance (a shift of the distance zero changes L like d ln L/dx, smooth in x). A separation that such a
change can fake is not evidence for either model. The rival refitted to the campaign and the planned readings is
therefore refitted once more with this freedom on the planned readings (``absorbed_fit``), profiled by turns: the
calibration change that best fits the rival's residuals on the new run is taken out of the planned readings and the
rival refitted, until the chi-square stops falling.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ecds_lab.analysis.fitting import FitResult
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.data.measurements import Measurements
from ecds_lab.planning.rivals import Rival, chi2_of, weighted_fit

#: Turns of the profiled refit at most, and the fall of chi-square (noise variances) below which it stops.
TURNS, SETTLED_CHI2 = 6, 1.0


def calibration_change_columns(planned: Measurements) -> np.ndarray:
    """The smooth calibration changes of a run, one column per freedom (ppm of L per unit): per frequency an
    offset and a drift linear in time over the run, and where the run sweeps distances a change linear and
    quadratic in distance (over the run's span)."""
    time = planned.time_s - (planned.time_s.min() if len(planned) else 0.0)
    time = time / max(float(np.ptp(planned.time_s)) if len(planned) else 0.0, 1.0)
    placed = np.isfinite(planned.x_m)
    x = np.where(placed, planned.x_m, 0.0)
    span = float(np.ptp(x[placed])) if placed.any() else 0.0
    u = (x - (x[placed].min() if placed.any() else 0.0)) / span if span > 0 else np.zeros(len(planned))
    columns = []
    for frequency in np.unique(planned.freq_hz):
        rows = (planned.freq_hz == frequency).astype(float)
        columns += [rows, rows * time]
        if span > 0:
            columns += [rows * placed * u, rows * placed * u**2]
    return np.array(columns, float).T.reshape(len(planned), -1)


def absorbed_fit(rival: Rival, campaign: Measurements, truth_readings: Measurements, refit: FitResult,
                 noise: NoiseEstimate) -> FitResult:
    """``rival`` refitted to the campaign and ``truth_readings`` (the planned readings as the truth predicts them;
    ``refit``: its fit there) with, besides, a smooth calibration change of the planned readings free."""
    columns = calibration_change_columns(truth_readings)
    change = np.zeros(columns.shape[1])
    best, best_chi2 = refit, chi2_of(refit, noise)
    rows = slice(len(campaign), None)
    for _ in range(TURNS):
        weights = best.weights[rows] if best.weights is not None else np.ones(len(truth_readings))
        step, *_ = np.linalg.lstsq(columns * weights[:, None], best.residuals_ppm[rows] * weights, rcond=None)
        trial = change - step  # a residual is measured / predicted - 1 (ppm): take the change out of the readings
        readings = dataclasses.replace(truth_readings, ls_h=truth_readings.ls_h * (1.0 + 1e-6 * (columns @ trial)))
        fit = weighted_fit(rival.model, Measurements.concatenate([campaign, readings]), noise, best.values,
                           rival.held)
        chi2 = chi2_of(fit, noise)
        if chi2 >= best_chi2:
            break
        settled = best_chi2 - chi2 < SETTLED_CHI2
        best, best_chi2, change = fit, chi2, trial
        if settled:
            break
    return best
