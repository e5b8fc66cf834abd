"""Glitch readings: single readings far from their neighbours, excluded from the fit with the reason.

A glitch is an isolated reading: it stands far out (``THRESHOLD`` noise sigmas) from the running
median of the residual along its series of like readings (``noise.smooth_residual``), while
everything around it agrees with the model. A deviation that belongs to a run of structure is
physics an effect may explain (a sweep made before a thermal state settled, a conductivity change
at close range), never a glitch, so a suspect is kept when

- a neighbour in time of the same frequency (the reading before or after it in its series)
  deviates the same way by more than ``REPEATED`` sigmas and a tenth of the suspect's deviation
  (``RUN_SHARE``): the deviation runs on in time or in x;
- the reading of the same state at another frequency, taken moments apart, deviates by more than
  ``REPEATED`` sigmas and a tenth of the suspect's deviation (either way: the bridge errs on one reading,
  physics shows at every frequency, by the frequencies' sensitivities within a factor of a few, not a
  thousand: a reading 1000 sigmas off whose partner at the other frequency is 3.5 sigmas off, the partner's
  repeat 3.5 sigmas the other way, is a glitch beside noise);
- readings of the same state elsewhere in the campaign (same frequency, direction and commanded
  distance) share the deviation: their median by more than ``REPEATED`` sigmas, or at least a
  ``SHARED`` part of them beyond ``THRESHOLD`` the same way.
The running median repeats the end values of a run, so the first and last reading of a run (a sweep's
turning points) are judged against the readings next to them instead, and only far beyond the threshold
(``END_THRESHOLD``): a peak of the residual there is structure as often as not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ecds_lab.analysis.noise import reading_groups, smooth_residual
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.row_labels import row_labels

#: Deviation from the local smooth, in noise sigmas, that marks a glitch (about one false flag in
#: 10^6 readings of Gaussian noise).
THRESHOLD = 5.5
#: Readings of the same state deviating alike (by this many sigmas, median) make it structure.
REPEATED = 3.0
#: A neighbour continues a run of structure when it deviates the same way by REPEATED sigmas and by at least this
#: share of the suspect's deviation: physics in time or x is smooth from one reading to the next, so a reading
#: 800 sigmas off beside one 3 sigmas off is a glitch beside noise, not a run.
RUN_SHARE = 0.1
#: The first and last reading of a run are judged against this many readings next to them, and are glitches
#: only beyond END_THRESHOLD sigmas.
END_SPAN = 3
END_THRESHOLD = 2 * THRESHOLD


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


#: Readings of one state with coil and target this close in temperature (K) are alike (``_judge_short_series``).
SAME_TEMPERATURE_K = 2.0
#: Share of the other readings of the same state beyond ``THRESHOLD`` the same way that makes a deviation
#: shared (a few hot sweeps among cold ones), while a second glitch among hundreds of readings does not.
SHARED = 0.1
#: Readings of one state at different frequencies at most this far apart in time (s) were taken together.
PARTNER_GAP_S = 60.0


def find_glitches(data: Measurements, residuals_ppm: np.ndarray, noise_ppm: float | np.ndarray) -> np.ndarray:
    """Boolean mask of glitch readings: isolated readings far from their neighbours (module docstring).
    ``noise_ppm`` is one figure or each reading's own (``NoiseEstimate.reading_sigma_ppm(data)``): a reading
    of a noisy phase (a heater ramping) is judged against its own noise, so its scatter is not a glitch."""
    r = np.asarray(residuals_ppm, float)
    sigma = np.broadcast_to(np.asarray(noise_ppm, float), r.shape)
    if not len(r) or not (sigma > 0).all():
        return np.zeros(len(r), bool)
    groups = reading_groups(data)
    positions = _PositionGroups.of(data)
    deviation = glitch_deviation(data, r, sigma, groups, positions)
    suspect = np.abs(deviation) > THRESHOLD
    neighbours = _time_neighbours(data, groups)
    out = np.zeros(len(r), bool)
    for i in np.flatnonzero(suspect).tolist():
        out[i] = not _in_structure(data, deviation, neighbours, i, positions.rows_like(i))
    return out


def glitch_deviation(data: Measurements, residuals_ppm: np.ndarray, sigma: np.ndarray,
                     groups: list[np.ndarray] | None = None, positions: _PositionGroups | None = None) -> np.ndarray:
    """Each reading's deviation (sigmas) from the running median of its series. The running median repeats a
    run's end values, so the first and last reading are instead judged against the median of the END_SPAN
    readings next to them, and only beyond END_THRESHOLD and when no repeated reading of the same point among
    them deviates alike (a turning point may bend the residual, and its repeats with it; a reading a thousand
    sigmas off the three after it, the first of a campaign say, is still a glitch); a reading of a series too short
    for either, against its state elsewhere (``_judge_short_series``). ``groups``: the series
    (``noise.reading_groups``) and ``positions`` (``_PositionGroups``) when the caller has them already."""
    r = np.asarray(residuals_ppm, float)
    groups = groups if groups is not None else reading_groups(data)
    deviation = (r - smooth_residual(data, r, groups=groups)) / sigma
    x = np.where(np.isfinite(data.x_commanded_m), data.x_commanded_m, np.inf)
    short = [rows for rows in groups if len(rows) <= END_SPAN]
    if short:
        _judge_short_series(data, r, sigma, np.concatenate(short), deviation,
                            positions if positions is not None else _PositionGroups.of(data))
    for rows in groups:
        if len(rows) <= END_SPAN:
            continue
        for end, inner in ((rows[0], rows[1:END_SPAN + 1]), (rows[-1], rows[-END_SPAN - 1:-1])):
            level = float(np.median(r[inner]))
            off = (r[end] - level) / sigma[end]
            twins = inner[x[inner] == x[end]]  # repeated readings of the turning point share its physics
            shared = np.sign(r[twins] - level) == np.sign(off)
            shared &= np.abs(r[twins] - level) / sigma[twins] > max(REPEATED, RUN_SHARE * abs(off))
            if abs(off) > END_THRESHOLD and not shared.any():
                deviation[end] = off
    return deviation


def _judge_short_series(data: Measurements, r: np.ndarray, sigma: np.ndarray, rows: np.ndarray,
                        deviation: np.ndarray, states: _PositionGroups) -> None:
    """Readings of series too short for a running median (``rows``: a repeat pair where a hot run begins, the slide
    arriving from above) judged against the median of the readings of their state (frequency, direction, commanded
    distance) at the same coil and target temperatures (within SAME_TEMPERATURE_K) elsewhere, at least two of them,
    and only beyond END_THRESHOLD, as a run's ends are: within the pair a glitch cannot be told from its twin
    (validation study seed 2030 case 172: a 2.6 % glitch there was never a suspect, bent the fit by 2600 ppm at
    20 mm and became a false alarm "outside the library"). Sets ``deviation`` of those beyond it; ``states``: the
    rows of each state of the slide (``_PositionGroups``)."""
    for i in rows.tolist():
        like = states.rows_like(i)
        like = like[(like != i) & (data.freq_hz[like] == data.freq_hz[i])
                    & (np.abs(data.t_coil_c[like] - data.t_coil_c[i]) <= SAME_TEMPERATURE_K)
                    & (np.abs(data.t_target_c[like] - data.t_target_c[i]) <= SAME_TEMPERATURE_K)]
        if len(like) < 2:
            continue
        off = (r[i] - float(np.median(r[like]))) / sigma[i]
        if abs(off) > END_THRESHOLD:
            deviation[i] = off


def _time_neighbours(data: Measurements, groups: list[np.ndarray] | None = None) -> np.ndarray:
    """For every row, the rows before and after it in its series of like readings (-1 where none)."""
    out = np.full((len(data), 2), -1, int)
    for rows in groups if groups is not None else reading_groups(data):
        out[rows[1:], 0] = rows[:-1]
        out[rows[:-1], 1] = rows[1:]
    return out


@dataclass(frozen=True)
class _PositionGroups:
    """The rows of each state of the slide: same commanded distance (or in air) and direction. Looked up per
    suspect, so judging a suspect costs the size of its group, not of the data (the data hold thousands of
    suspects where the model misses physics)."""

    group: np.ndarray
    order: np.ndarray
    starts: np.ndarray

    @classmethod
    def of(cls, data: Measurements) -> _PositionGroups:
        x = np.where(np.isinf(data.x_commanded_m), np.inf, data.x_commanded_m)
        group = row_labels(data.direction, x)
        order = np.argsort(group, kind="stable")
        starts = np.searchsorted(group[order], np.arange(group.max(initial=-1) + 2))
        return cls(group, order, starts)

    def rows_like(self, i: int) -> np.ndarray:
        """The rows of row ``i``'s state (itself included), in row order."""
        g = self.group[i]
        return self.order[self.starts[g]:self.starts[g + 1]]


def _in_structure(data: Measurements, deviation: np.ndarray, neighbours: np.ndarray, i: int,
                  position: np.ndarray) -> bool:
    """Whether the deviation of row ``i`` belongs to a run of structure (see the module docstring);
    ``position``: the rows at its commanded distance (or in air with it) in the same direction."""
    sign = np.sign(deviation[i])
    run = max(REPEATED, RUN_SHARE * abs(deviation[i]))
    for j in neighbours[i]:
        if j >= 0 and np.sign(deviation[j]) == sign and abs(deviation[j]) > run:
            return True
    partners = position[(data.segment[position] == data.segment[i]) & (data.freq_hz[position] != data.freq_hz[i])
                        & (np.abs(data.time_s[position] - data.time_s[i]) <= PARTNER_GAP_S)]
    if np.any(np.abs(deviation[partners]) > run):
        return True
    same = position[(data.freq_hz[position] == data.freq_hz[i]) & (position != i)]
    others = deviation[same]
    if not len(others):
        return False
    median = float(np.median(others))
    return (np.sign(median) == sign and abs(median) > REPEATED) or float(np.mean(others * sign > THRESHOLD)) >= SHARED


def describe(data: Measurements, rows: np.ndarray, residuals_ppm: np.ndarray, noise_ppm: float | np.ndarray,
             index: np.ndarray, earlier: Sequence[Outlier] = (), original: Measurements | None = None
             ) -> list[Outlier]:
    """Outlier records for ``rows`` (indices into ``data``), numbered by ``index`` (original rows); ``noise_ppm``
    as for ``find_glitches``. ``earlier``: the readings excluded before these (rows of ``original``, the data
    ``index`` numbers): a reading of the same state among them no longer vouches for these, and the reason says so."""
    sigma = np.broadcast_to(np.asarray(noise_ppm, float), np.shape(residuals_ppm))
    deviation = glitch_deviation(data, residuals_ppm, sigma)
    # a state as the rules judge it (``_in_structure``): the slide's state (``_PositionGroups``) and the frequency
    states = _PositionGroups.of(original) if earlier and original is not None else None
    out = []
    for i in rows:
        where = "coil in air" if not np.isfinite(data.x_m[i]) else f"x = {data.x_m[i] * 1e3:.4g} mm"
        row = int(index[i])
        twins = [] if states is None or original is None else [
            o.row for o in earlier
            if states.group[o.row] == states.group[row] and original.freq_hz[o.row] == original.freq_hz[row]]
        repeated = ("not repeated by readings of the same state" if not twins else
                    "not repeated by the readings of the same state still in the fit (row "
                    f"{', '.join(str(t) for t in twins)}, of the same state, was excluded as a glitch before it)")
        out.append(Outlier(row, float(data.ls_h[i]), float(deviation[i]),
                           f"glitch: {deviation[i]:+.1f} sigma from its neighbours ({where}, "
                           f"{data.freq_hz[i]:g} Hz, t = {data.time_s[i]:.0f} s), {repeated}; excluded from the fit"))
    return out

