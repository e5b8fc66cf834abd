"""slide_lead_screw: the slide's lead screw has a periodic positioning error over each revolution.

A stepper slide's position comes from counting the screw's turns; thread-form errors, an
eccentric or bent screw and a wobbling nut ("drunken thread") make the carriage run ahead and
behind in a cycle of one screw lead. Its first harmonic is x_true = x + A sin(2 pi x / p + phi).
In quadrature, x_eff = x + a sin(2 pi x / p) + b cos(2 pi x / p): a and b enter linearly, the lead
p is the one nonlinear parameter (the sign of x relative to the machine coordinate only moves phi).
The same position shows the same error from either direction (unlike backlash or random scatter
between moves). Positions taken on a regular grid g alias a lead to others (p and 1/(1/p + k/g)):
only leads longer than twice the steps can be told, and only where the steps sample the screw's
turns in a run (``RESOLVING_STEPS`` consecutive steps, two samples per turn over two turns): one pair
of close positions among coarser steps resolves no turn, and a lead it seemed to allow is an alias
(0.78 mm on 0.75 mm steps reads as a wave of 22 mm). A shorter lead therefore moves nothing in these
data (its error is not determinable, so never claimed), and the effect is tested only where the steps
resolve at least the longest lead it declares (20 mm: runs of steps of 10 mm or less).

The lead is found over the whole declared range by a scan of the residual over leads: the current
model's residual as a distance error, detrended by a cubic in x per direction and frequency, in a
weighted Lomb-Scargle periodogram (``periodogram``) over leads from the shortest the positions resolve
to 20 mm; the best peaks, with their sine and cosine parts, are the fit's starts
(``starts_from_residual``), then the fit refines them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import Effect, register
from ecds_lab.model.library.remembered import Remembered
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import Tangent, plus

#: Physically possible leads (m): fine screws of 0.5 mm up to the 20 mm of fast ball screws.
LEAD_RANGE_M = (0.5e-3, 20e-3)
#: Common leads of slide screws (m): metric threads, trapezoidal and ball screws.
COMMON_LEADS_M = (1e-3, 2e-3, 2.5e-3, 4e-3, 5e-3, 8e-3, 10e-3)
#: A period needs this many distinct positions (3 parameters and a margin against chance).
MIN_POSITIONS = 8
#: A lead is resolved by a run of this many consecutive steps each at most half of it (two turns, two samples
#: per turn: Nyquist over more than one turn).
RESOLVING_STEPS = 4
#: Leads scanned by the periodogram (log-spaced over the resolvable part of LEAD_RANGE_M), and peaks kept.
LEAD_GRID = 600
PEAKS = 3
#: Degree of the polynomial in x removed per direction and frequency before the scan (smooth trends).
DETREND_DEGREE = 3
_NAMES = ("screw_sin", "screw_cos", "screw_lead")


@register
class SlideLeadScrew(Effect):
    name = "slide_lead_screw"
    explains = "the slide's lead screw runs ahead and behind in a cycle of one screw revolution"
    #: Periodic errors of a slide screw are micrometres to tens of micrometres (the paper's slide: accuracy in
    #: the low tens of um); the lead is that of a real screw.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"screw_sin": (-50e-6, 50e-6),
                                                           "screw_cos": (-50e-6, 50e-6),
                                                           "screw_lead": LEAD_RANGE_M}
    key_parameters = ("screw_sin", "screw_cos")
    reveal = ("step finer than the screw's lead (e.g. 0.5 mm steps over two turns), or check the positions "
              "against a laser or dial-gauge reference")
    reveal_needs: ClassVar[dict[str, float]] = {"finest_step_mm": 0.5}
    #: The other common leads (the longest is the default start, which every testable campaign resolves).
    alternative_starts = tuple({"screw_lead": lead} for lead in COMMON_LEADS_M[:-1])

    def __init__(self, sensor: SensorConfig) -> None:
        super().__init__(sensor)
        self._shortest: Remembered[float] = Remembered()

    def parameters(self) -> list[Parameter]:
        return [
            Parameter("screw_sin", 0.0, -200e-6, 200e-6, "m", "periodic error of the screw, sine part", 2e-6),
            Parameter("screw_cos", 0.0, -200e-6, 200e-6, "m", "periodic error of the screw, cosine part", 2e-6),
            Parameter("screw_lead", COMMON_LEADS_M[-1], 0.3e-3, 30e-3, "m", "lead of the screw (travel per revolution)",
                      0.1e-3),
        ]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        count, step = _positions(data)
        if count < MIN_POSITIONS:
            return {n: f"{count} distinct positions (a periodic error needs {MIN_POSITIONS})" for n in _NAMES}
        if 2 * step >= LEAD_RANGE_M[1] * (1 - 1e-6):  # (positions to 1 um: their spacing rounds)
            return {n: f"the positions are {step * 1e3:.3g} mm apart or more in every run of {RESOLVING_STEPS} "
                       f"steps: no screw lead of {LEAD_RANGE_M[1] * 1e3:g} mm or less can be resolved (it needs "
                       f"steps shorter than {LEAD_RANGE_M[1] * 500:g} mm)" for n in _NAMES}
        return {}

    def signature(self, data: Measurements, values: Mapping[str, float]) -> tuple[float, dict[str, float]] | None:
        """ln of the error's amplitude sqrt(a^2 + b^2). Near an alias of the positions' grid (a lead close to twice
        the step) the sine and cosine parts sample one pattern: one combination of them is determined, the
        amplitude is not, and a joint test of the two parts passes on that combination alone (seed 2032 case 128 of
        the study: 16 positions 5.33 mm apart, a lead of 10.8 mm, 50 um +- 2.5 mm, joint Wald 77, from per-position
        errors that no screw made). A periodic error is claimed only with its amplitude known."""
        a, b = values["screw_sin"], values["screw_cos"]
        squared = a * a + b * b
        if not squared > 0:
            return None
        return 0.5 * math.log(squared), {"screw_sin": a / squared, "screw_cos": b / squared}

    def starts_from_residual(self, data: Measurements, shift_m: np.ndarray,
                             weights: np.ndarray) -> tuple[dict[str, float], ...]:
        """The best peaks of a weighted Lomb-Scargle periodogram of the residual distance error over the
        resolvable leads (see the module docstring), each with its sine and cosine parts."""
        count, step = _positions(data)
        shortest = max(LEAD_RANGE_M[0], 1.02 * 2 * step)
        if count < MIN_POSITIONS or shortest >= LEAD_RANGE_M[1]:
            return ()
        leads = np.geomspace(shortest, LEAD_RANGE_M[1], LEAD_GRID)
        omega = 2 * np.pi / leads
        groups = _detrended(data, shift_m, weights)
        if not groups:
            return ()
        power = np.zeros(len(leads))
        for x, y, w in groups:
            power += periodogram(x, y, w, omega)
        peaks = [i for i in range(len(leads)) if power[i] >= power[max(i - 1, 0)] and power[i] >= power[min(i + 1,
                 len(leads) - 1)]]
        peaks.sort(key=lambda i: -power[i])
        x_all = np.concatenate([x for x, _, _ in groups])
        y_all = np.concatenate([y for _, y, _ in groups])
        root_w = np.sqrt(np.concatenate([w for _, _, w in groups]))
        starts = []
        for i in peaks[:PEAKS]:
            phase = 2 * np.pi * x_all / leads[i]
            design = np.column_stack([np.sin(phase), np.cos(phase)]) * root_w[:, None]
            (a, b), *_ = np.linalg.lstsq(design, y_all * root_w, rcond=None)
            limit = 0.9 * self.parameters()[0].upper
            starts.append({"screw_lead": float(leads[i]), "screw_sin": float(np.clip(a, -limit, limit)),
                           "screw_cos": float(np.clip(b, -limit, limit))})
        return tuple(starts)

    def shortest_lead(self, data: Measurements) -> float:
        """The shortest lead these positions resolve (m): twice their resolving step (``_positions``; remembered per
        data)."""
        return self._shortest.get(data, None, lambda: 2 * _positions(data)[1])

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        if p["screw_lead"] < self.shortest_lead(data):  # an alias of a longer lead: nothing these data can tell
            return x_m
        finite = np.isfinite(data.x_m)
        phase = 2 * np.pi * np.where(finite, data.x_m, 0.0) / p["screw_lead"]
        error = p["screw_sin"] * np.sin(phase) + p["screw_cos"] * np.cos(phase)
        return x_m + np.where(finite, error, 0.0)

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        if p["screw_lead"] < self.shortest_lead(data):  # as effective_distance: nothing moves, nothing to derive
            return x_m, dx
        finite = np.isfinite(data.x_m)
        x = np.where(finite, data.x_m, 0.0)
        phase = 2 * np.pi * x / p["screw_lead"]
        sin, cos = np.where(finite, np.sin(phase), 0.0), np.where(finite, np.cos(phase), 0.0)
        # d phase / d lead = -phase / lead
        d_lead = (p["screw_sin"] * cos - p["screw_cos"] * sin) * (-phase / p["screw_lead"])
        own = {"screw_sin": sin, "screw_cos": cos, "screw_lead": d_lead}
        return x_m + p["screw_sin"] * sin + p["screw_cos"] * cos, plus(dx, own)


def periodogram(x: np.ndarray, y: np.ndarray, w: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """At each angular frequency of ``omega`` (rad/m), how much a sinusoid lowers the weighted sum of squares of
    ``y`` about its weighted mean: the generalised (floating-mean, weighted) Lomb-Scargle periodogram of Zechmeister
    and Kuerster (A&A 496, 577, 2009) before its normalisation by that sum, from the normal equations of the fit of
    a cos(omega x) + b sin(omega x) + c, whose sums are taken per distinct position (each position's readings share
    its sinusoid). It equals ``scipy.signal.lombscargle(..., weights=w, floating_mean=True, normalize=True)`` times
    that sum; written here because importing scipy.signal (its docstrings are processed on import) cost every
    diagnosis 0.5 s before its first fork, for this one scan."""
    positions, index = np.unique(x, return_inverse=True)
    w_at = np.bincount(index, weights=w)
    wy_at = np.bincount(index, weights=w * y)
    phase = np.outer(omega, positions)
    c, s = np.cos(phase), np.sin(phase)
    normal = np.empty((len(omega), 3, 3))
    normal[:, 0, 0], normal[:, 1, 1], normal[:, 2, 2] = (c * c) @ w_at, (s * s) @ w_at, w_at.sum()
    normal[:, 0, 1] = normal[:, 1, 0] = (c * s) @ w_at
    normal[:, 0, 2] = normal[:, 2, 0] = c @ w_at
    normal[:, 1, 2] = normal[:, 2, 1] = s @ w_at
    right = np.column_stack([c @ wy_at, s @ wy_at, np.full(len(omega), wy_at.sum())])
    try:
        solution = np.linalg.solve(normal, right[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:  # every position at one phase of some lead: no sinusoid there beyond the mean
        solution = (np.linalg.pinv(normal) @ right[:, :, None])[:, :, 0]
    explained = np.einsum("fi,fi->f", right, solution)
    return explained - wy_at.sum() ** 2 / w_at.sum()


def _detrended(data: Measurements, shift_m: np.ndarray, weights: np.ndarray
               ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(x, distance error less a weighted cubic in x, weights) per direction and frequency, readings with a
    finite error and weight only (far from the coil a small sensitivity makes the error noisy: low weight)."""
    shift = np.asarray(shift_m, float)
    w_all = np.asarray(weights, float)
    usable = np.isfinite(data.x_m) & np.isfinite(shift) & np.isfinite(w_all) & (w_all > 0)
    out = []
    for direction in np.unique(data.direction[usable]):
        for freq in np.unique(data.freq_hz[usable]):
            rows = usable & (data.direction == direction) & (data.freq_hz == freq)
            x, y, w = data.x_m[rows], shift[rows], w_all[rows]
            if len(np.unique(np.round(x, 6))) < MIN_POSITIONS:
                continue
            y = y - np.polyval(np.polyfit(x, y, DETREND_DEGREE, w=np.sqrt(w)), x)
            out.append((x, y, w))
    return out


def _positions(data: Measurements) -> tuple[int, float]:
    """How many distinct positions (to 1 um) the data hold, and their resolving step (m; inf for too few): the
    longest step in their finest run of ``RESOLVING_STEPS`` consecutive steps."""
    positions = np.unique(np.round(data.x_m[np.isfinite(data.x_m)], 6))
    steps = np.diff(positions)
    if len(steps) < RESOLVING_STEPS:
        return len(positions), math.inf
    return len(positions), float(np.lib.stride_tricks.sliding_window_view(steps, RESOLVING_STEPS).max(axis=1).min())
