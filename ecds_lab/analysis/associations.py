"""Where does the residual live? A score per recorded variable, strongest first.

For each variable the residual (ppm of L) is averaged in bins of that variable, within each
frequency (an effect often differs between 500 Hz and 15 kHz). The score is the share of the
residual's energy those bin means explain beyond what noise alone would explain by chance,
so pure noise scores about 0 and a residual that is a clean function of the variable about 1.
The frequency itself is scored on the offsets between frequencies, every other variable on the
residual within each frequency. Variables that only count along a campaign (time, the coil's
temperature rate) are scored on the variation within each phase (``analysis.phases``): the
differences between phases are what the set-up did in between, and the state variables (x,
temperatures, direction) are the ones to explain them. Given how well the noise is known (``uncertainty``:
``NoiseEstimate.variance_shares``), the significance leaves a margin for the noise estimate's own scatter
(``analysis.noise_margin``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ecds_lab.analysis.grouping import visit_labels
from ecds_lab.analysis.noise_margin import loadings, significance
from ecds_lab.analysis.phases import phase_labels, within_phase
from ecds_lab.data.columns import VARIABLES, Variable
from ecds_lab.data.measurements import Measurements

MAX_BINS = 10
#: A category of a categorical variable (a direction of approach, a frequency) counts only where readings of it come
#: from at least this many visits (``analysis.grouping.visit_labels``: one stop of the slide). The readings of one
#: visit share its carriage error and the moment's state, so a category seen at one visit is that visit: in a
#: campaign of forward sweeps the only readings approached downward are the first of a later sweep, whose offset
#: is whatever that moment holds (a hot sweep's first reading after the coil came from the air), not the direction.
MIN_VISITS = 2
#: Time is confounded with every phase of a campaign, so it ranks first only when it explains
#: clearly more than every physical variable (by this factor).
TIME_MARGIN = 1.25
#: Scored on the variation within each phase of the campaign.
WITHIN_PHASE = ("time_s", "coil_rate_k_per_min")
#: Time is weighed against the state variables among the first this many.
CONFOUNDED = 4
#: What time explains beyond a state variable must be this many standard deviations beyond chance to rank it first.
BEYOND_CHANCE = 3.0
#: What a summary says where no variable's share of the residual is beyond chance.
NONE_BEYOND_CHANCE = f"none is beyond chance, {BEYOND_CHANCE:g} sd: the residual is noise"


@dataclass(frozen=True)
class Association:
    """How much of the residual a variable explains (``score``), how far beyond chance that is
    (``significance``: standard deviations of the bin-means statistic above its value for pure
    noise of the estimated size), and in words (``detail``)."""

    variable: str
    score: float
    detail: str
    significance: float = 0.0


def _bin_index(values: np.ndarray, categorical: bool) -> tuple[np.ndarray, int]:
    """Bin number of every value: one bin per category, else up to MAX_BINS quantile bins."""
    if categorical:
        _, index = np.unique(values, return_inverse=True)
        return index, int(index.max()) + 1 if len(index) else 0
    unique = np.unique(values)
    if len(unique) <= MAX_BINS:
        _, index = np.unique(values, return_inverse=True)
        return index, len(unique)
    edges = np.unique(np.quantile(values, np.linspace(0, 1, MAX_BINS + 1)))
    index = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, len(edges) - 2)
    return index, len(edges) - 1


def _binned(values: np.ndarray, categorical: bool, groups: list[np.ndarray]
            ) -> Iterator[tuple[np.ndarray, np.ndarray, int]]:
    """Per group (a frequency, or all readings): its rows with a finite value (at least 3), their bin numbers and
    the number of bins."""
    for group in groups:
        rows = group & np.isfinite(values)
        if rows.sum() >= 3:
            yield (rows, *_bin_index(values[rows], categorical))


def _replicated(values: np.ndarray, visits: np.ndarray) -> np.ndarray:
    """A categorical variable's ``values``, NaN where their category was seen at fewer than MIN_VISITS visits."""
    out = values.astype(float)
    for value in np.unique(values[np.isfinite(values)]):
        level = values == value
        if len(np.unique(visits[level])) < MIN_VISITS:
            out[level] = np.nan
    return out


def _bin_means(r: np.ndarray, index: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Readings in each bin and their mean residual (0 for an empty bin)."""
    counts = np.bincount(index, minlength=bins)
    sums = np.bincount(index, weights=r, minlength=bins)
    return counts, np.divide(sums, counts, out=np.zeros(bins), where=counts > 0)


def _between(r: np.ndarray, index: np.ndarray, bins: int) -> tuple[float, int]:
    """Energy of the bin means about the mean, and the degrees of freedom it has under pure noise."""
    counts, means = _bin_means(r, index, bins)
    return float(np.sum(counts * (means - r.mean()) ** 2)), int((counts > 0).sum()) - 1


def _trend(v: np.ndarray, r: np.ndarray) -> float:
    """Change of the residual over the variable's range by a straight-line fit (ppm)."""
    if np.ptp(v) == 0:
        return 0.0
    slope = np.polyfit(v, r, 1)[0]
    return float(slope * np.ptp(v))


def _describe(variable: Variable, data: Measurements, values: np.ndarray, r: np.ndarray) -> str:
    """Plain words: how the residual changes with the variable, per frequency."""
    if variable.name == "freq_hz":
        parts = [f"{r[data.freq_hz == f].mean():+.0f} ppm at {f:g} Hz" for f in np.unique(data.freq_hz)]
        return "mean residual " + ", ".join(parts)
    if variable.name == "direction":
        parts = [f"{r[values == d].mean():+.0f} ppm when approaching {'upward' if d > 0 else 'downward'}"
                 for d in (1.0, -1.0) if (values == d).any()]
        return "mean residual " + " vs ".join(parts)
    changes = []
    for f in np.unique(data.freq_hz):
        rows = (data.freq_hz == f) & np.isfinite(values)
        if rows.sum() >= 3:
            changes.append((f, _trend(values[rows], r[rows]), float(np.nanmin(values[rows])),
                            float(np.nanmax(values[rows]))))
    if not changes:
        return "too few readings"
    text = ", ".join(f"{change:+.0f} ppm over {lo:.4g}..{hi:.4g} {variable.unit} at {f:g} Hz"
                     for f, change, lo, hi in changes)
    sizes = sorted(((abs(c), f) for f, c, _, _ in changes), reverse=True)
    if len(sizes) >= 2 and sizes[-1][0] > 0 and sizes[0][0] > 2 * sizes[-1][0]:
        text += f" ({sizes[0][0] / sizes[-1][0]:.1f}x larger at {sizes[0][1]:g} Hz)"
    return "residual changes by " + text


def residual_associations(data: Measurements, residuals_ppm: np.ndarray, noise_ppm: float,
                          uncertainty: tuple[np.ndarray, np.ndarray] | None = None) -> list[Association]:
    """Score every variable by how much of the residual it explains; strongest first. ``uncertainty``: each
    reading's shares in the noise estimates and their degrees of freedom (``NoiseEstimate.variance_shares``);
    without it the noise is taken as known.

    Time runs along the whole campaign, so a residual that lives in time (a drift of the bridge's gain) is
    partly explained by whatever state changed along the campaign (the coil heated last), and the other way
    round. Time goes before the first of the leading state variables (the first CONFOUNDED) it outranks in
    this sense: it explains more of what that variable leaves (its significance on the residual without the
    variable's bin means), beyond chance (BEYOND_CHANCE), than the variable explains of what time leaves. A
    drift between phases, hot sweeps and cooling in air, has little significance within a phase, yet leaves a
    target temperature nothing once time is taken out (validation study case 25: 0.1 sd against time's 5.5);
    and a coil temperature that wandered 0.1 K with the room is no more than a clock (case 27).
    ``significance`` stays each variable's own."""
    full = np.asarray(residuals_ppm, float)
    scorer = _Scorer(data, full, noise_ppm, uncertainty)
    out = [scorer.association(variable, full) for variable in VARIABLES.values()]
    ranked = sorted(out, key=lambda a: -(a.score / TIME_MARGIN if a.variable == "time_s" else a.score))
    time = next(a for a in ranked if a.variable == "time_s")
    clock = VARIABLES["time_s"]
    for state in [a for a in ranked[:CONFOUNDED] if a.variable not in ("time_s", "freq_hz")]:
        if ranked.index(time) < ranked.index(state):
            break
        lead = VARIABLES[state.variable]
        beyond_lead = scorer.association(clock, scorer.without(lead, full)).significance
        beyond_time = scorer.association(lead, scorer.without(clock, full)).significance
        if beyond_lead <= max(BEYOND_CHANCE, beyond_time):
            continue
        ranked.remove(time)
        ranked.insert(ranked.index(state), dataclasses.replace(
            time, detail=f"{time.detail}; along the campaign it explains what {state.variable} does ({beyond_lead:.1f} "
                         f"sd beyond it, {state.variable} {beyond_time:.1f} sd beyond time)"))
        break
    return ranked


class _Scorer:
    """The bin-means statistic of each variable on a residual (per frequency; time-like variables within phases)."""

    def __init__(self, data: Measurements, full: np.ndarray, noise_ppm: float,
                 uncertainty: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self.data, self.noise_ppm = data, noise_ppm
        empty = (np.zeros((len(data), 0)), np.zeros(0))
        self.shares: np.ndarray = (uncertainty or empty)[0]
        self.dof: np.ndarray = (uncertainty or empty)[1]
        self.frequencies = [data.freq_hz == f for f in np.unique(data.freq_hz)]
        self.total = float(np.sum((full - full.mean()) ** 2)) or 1.0
        self.within = sum(float(np.sum((full[g] - full[g].mean()) ** 2)) for g in self.frequencies) or 1.0
        self.labels = phase_labels(data)
        self.visits = visit_labels(data)

    def without(self, variable: Variable, r: np.ndarray) -> np.ndarray:
        """``r`` minus its mean in each bin of ``variable`` (per frequency): what the variable does not explain."""
        out = r.copy()
        for rows, index, bins in _binned(self.values(variable), variable.categorical, self.frequencies):
            out[rows] = r[rows] - _bin_means(r[rows], index, bins)[1][index]
        return out

    def values(self, variable: Variable) -> np.ndarray:
        """The variable's values, a category seen at fewer than MIN_VISITS visits left out (NaN)."""
        values = variable.values(self.data)
        return _replicated(values, self.visits) if variable.categorical else values

    def association(self, variable: Variable, full: np.ndarray) -> Association:
        data, noise_ppm = self.data, self.noise_ppm
        values = self.values(variable)
        r = within_phase(full, self.labels, data.freq_hz) if variable.name in WITHIN_PHASE else full
        between, dof = 0.0, 0
        loads = np.zeros(len(self.dof))
        groups = [np.ones(len(r), bool)] if variable.name == "freq_hz" else self.frequencies
        for rows, index, bins in _binned(values, variable.categorical, groups):
            if bins < 2:
                continue
            energy, groups_dof = _between(r[rows], index, bins)
            between, dof = between + energy, dof + groups_dof
            # bin means about the group's mean: each estimate's loading less its mean share over the group
            loads += loadings(index, self.shares[rows]) - self.shares[rows].mean(axis=0)
        # Under pure noise of a known size, between / noise^2 is chi-square with dof degrees of freedom.
        explained = max(0.0, between - dof * noise_ppm**2)
        beyond = significance(between / noise_ppm**2, dof, loads, self.dof) if dof and noise_ppm > 0 else 0.0
        # Frequency is scored against all the residual, every other variable against what is
        # left within each frequency (an offset between frequencies is the frequency's to explain).
        score = min(1.0, explained / (self.total if variable.name == "freq_hz" else self.within))
        return Association(variable.name, round(score, 4), _describe(variable, data, values, r),
                           round(float(beyond), 1))
