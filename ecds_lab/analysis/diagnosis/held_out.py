"""Cross-validation: the screening subsample, grouped folds and the held-out error a claim must lower."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ecds_lab import forked
from ecds_lab.analysis.diagnosis.nuisance import held_in_folds
from ecds_lab.analysis.diagnosis.result import Candidate
from ecds_lab.analysis.fitting import FitResult, fit_model, referenced
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.analysis.phases import phase_labels
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.row_labels import row_labels

FOLDS = 4
#: Bands of distance (or stretches of time in air) per phase that are held out together.
BLOCKS = 8
#: A block whose target or coil temperature spans more than this (K) is held out visit by visit.
VISIT_SPLIT_SPAN_K = 5.0
#: Campaigns larger than this are screened on an even subsample of this many readings.
SCREEN_ROWS = 2500
#: Fold number of readings that always train (the end bands of distance).
NEVER_HELD_OUT = -1
#: A claim must lower the held-out sum of squares by at least this many noise variances (``held_out_gain``).
HELD_OUT_CHI2 = 10.0


def held_out_gain(base_cv: float, cv: float, n: int, noise: NoiseEstimate) -> float:
    """The fall of the held-out sum of squares in noise variances (of the larger of the noise and the
    candidate's held-out error, as for the fitted chi-square gain), divided by the design effect."""
    scale2 = max(noise.ppm**2, cv**2)
    return n * (base_cv**2 - cv**2) / scale2 / max(noise.design_effect, 1.0) if scale2 > 0 else 0.0


def check_held_out(candidate: Candidate, base_cv: float | None, folds: np.ndarray, data: Measurements,
                   noise: NoiseEstimate, cv: float | None = None) -> None:
    """The grouped held-out error must fall below the current model's by a margin in noise units:
    its sum of squares by at least HELD_OUT_CHI2 noise variances (115.0 against 115.2 ppm over a few
    hundred readings at 20 ppm noise is a fall of about 2: no evidence). ``cv``: the candidate's held-out error
    (``cv_rmse``) when the caller has it already."""
    candidate.base_cv_rmse_ppm = base_cv
    candidate.cv_rmse_ppm = cv if cv is not None else cv_rmse(data, candidate.fit, folds)
    scored = int(np.sum(folds != NEVER_HELD_OUT))
    gain = held_out_gain(base_cv, candidate.cv_rmse_ppm, scored, noise) if base_cv is not None else 0.0
    candidate.held_out_gain = gain
    candidate.checks["held_out"] = base_cv is not None and gain >= HELD_OUT_CHI2
    if not candidate.checks["held_out"]:
        candidate.rejected.append(f"held-out error {candidate.cv_rmse_ppm:.1f} ppm against the current model's "
                                  f"{base_cv:.1f} ppm is a fall of {gain:.1f} noise variances "
                                  f"(needs {HELD_OUT_CHI2:g})")


def folds_of(data: Measurements) -> np.ndarray | None:
    """Fold number per row: blocks of neighbouring readings (a phase's readings in one band of distance,
    or a stretch of time for the coil in air) dealt to the folds at random; None if too few readings.

    Whole blocks are held out, so a fold is not predicted from its immediate neighbours, while every
    fold keeps each phase's temperatures (held-out error measures interpolation, not extrapolation
    of a temperature the fit never saw). For the same reason the nearest and the farthest band of
    distance are never held out (``NEVER_HELD_OUT``): an effect with its own values along x (tau(x)'s
    nodes) would otherwise be judged on how it extrapolates beyond the readings it was fitted to."""
    if len(data) < 8 * FOLDS:
        return None
    phases = phase_labels(data)
    block = np.zeros(len(data), int)
    finite = np.isfinite(data.x_m)
    if finite.any():
        edges = np.unique(np.quantile(data.x_m[finite], np.linspace(0, 1, BLOCKS + 1)))
        block[finite] = np.clip(np.searchsorted(edges, data.x_m[finite], side="right") - 1, 0, BLOCKS - 1)
    for phase in np.unique(phases[~finite]):
        rows = np.flatnonzero((phases == phase) & ~finite)
        rows = rows[np.argsort(data.time_s[rows], kind="stable")]
        block[rows] = np.arange(len(rows)) * BLOCKS // max(len(rows), 1)
    groups = row_labels(phases, block, finite)
    groups = _split_visits(data, groups)
    unique = np.unique(groups)
    if len(unique) < 2 * FOLDS:
        return None
    rng = np.random.default_rng(0)
    fold_of_group = rng.permutation(len(unique)) % FOLDS
    folds = fold_of_group[groups]
    if finite.any():  # the nearest and farthest band always train: held out, they would test extrapolation in x
        folds[finite & ((block == 0) | (block == block[finite].max()))] = NEVER_HELD_OUT
    return folds if len(np.unique(folds[folds != NEVER_HELD_OUT])) >= 2 else None


def _split_visits(data: Measurements, groups: np.ndarray) -> np.ndarray:
    """Blocks whose temperatures change (a heating ramp at one distance, sweeps of one band at several
    temperatures) split into their visits (stretches of consecutive readings in time): holding out the
    whole block would hold out that temperature history, and the fit would extrapolate in temperature."""
    order = np.argsort(data.time_s, kind="stable")
    visit = np.zeros(len(data), int)
    visit[order] = np.cumsum(np.concatenate([[0], groups[order][1:] != groups[order][:-1]]))
    out = groups.copy()
    for g in np.unique(groups):
        rows = groups == g
        span = max(float(np.ptp(data.t_target_c[rows])), float(np.ptp(data.t_coil_c[rows])))
        if span > VISIT_SPLIT_SPAN_K:
            out[rows] = -1 - visit[rows]  # a block per visit (negative: apart from the whole blocks)
    return np.unique(out, return_inverse=True)[1].ravel()


def cv_rmse(data: Measurements, full: FitResult, folds: np.ndarray) -> float:
    """Held-out RMS (ppm): fit without one fold, predict it; the model still sees the whole history. A nuisance
    smooth's coefficients (``nuisance.held_in_folds``) are held where the fit on every reading left them."""
    return cv_rmses(data, [full], folds)[0]


def cv_rmses(data: Measurements, fits: Sequence[FitResult], folds: np.ndarray) -> list[float]:
    """``cv_rmse`` of each of ``fits``, the folds of all of them fitted side by side (``forked.each``)."""
    held_out = HeldOutFits(data, fits, folds)
    return held_out.rmses(forked.each(held_out.squares, held_out.tasks(), shared=held_out.shared()))


def out_of_reach(full: FitResult, training: Measurements) -> dict[str, float]:
    """The parameters ``full`` fitted free that a fold's ``training`` readings leave out of reach
    (``Effect.held_out_of_reach``), at the values the effects hold them: never at the full fit's, which the
    held-out readings helped make."""
    free = set(full.free_names)
    return {name: value for effect in full.model.effects
            for name, value in effect.held_out_of_reach(training).items() if name in free}


@dataclass(frozen=True, eq=False)
class HeldOutFits:
    """The fits behind the held-out errors of ``fits`` on ``data``: one per model and fold, each independent of the
    others (``tasks``, each worked by ``squares``), so that they can be worked beside other fits (``cv_rmses``, and a
    claim's refit on every reading, ``search._full_fit_beside_starts``)."""

    data: Measurements
    fits: Sequence[FitResult]
    folds: np.ndarray

    def tasks(self) -> list[tuple[int, int]]:
        """(which fit, which fold) of every fit to make."""
        keys = np.unique(self.folds[self.folds != NEVER_HELD_OUT]).tolist()
        return [(which, k) for which in range(len(self.fits)) for k in keys]

    def squares(self, task: tuple[int, int]) -> float:
        """The held-out sum of squares (ppm^2) of one fit's fold: fitted without it, the model still seeing the
        whole history; a nuisance smooth's coefficients held where the fit on every reading left them."""
        which, k = task
        full, held = self.fits[which], self.folds == k
        fixed = {**out_of_reach(full, self.data.select(~held)), **(held_in_folds(full.model, full.values) or {})}
        trained = fit_model(full.model, self.data, start=full.values, fixed=fixed or None, multistart=False,
                            rows=~held, screening=True)
        r = (self.data.ls_h[held] / trained.predict(self.data)[held] - 1) * 1e6
        return float(r @ r)

    def rmses(self, squares: Sequence[float]) -> list[float]:
        """Each fit's held-out RMS (ppm) from the squares of its ``tasks``, in their order."""
        count = max(int((self.folds != NEVER_HELD_OUT).sum()), 1)
        per_fit = len(squares) // max(len(self.fits), 1)
        return [math.sqrt(sum(squares[which * per_fit:(which + 1) * per_fit]) / count)
                for which in range(len(self.fits))]

    def shared(self) -> list[object]:
        """What the fits refer to that a worker sends back as the caller's own (``fitting.referenced``)."""
        return [obj for full in self.fits for obj in referenced(self.data, full.model)]
