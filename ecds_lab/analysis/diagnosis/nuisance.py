"""A flexible nuisance for a residual outside the library: a smooth change in the variables it lives in.

When the search ends with structure the library does not describe, that structure (a drift of the bridge's gain
in time, a former re-absorbing humidity as the coil cools) weighs on every remaining candidate's evidence: a lead
screw's periodic error of 70 ppm is judged against a residual of 1500 ppm that lives in time and the coil's
temperature, not against the 23 ppm noise. The nuisance here takes that structure instead: cubic B-splines in
each variable the residual is associated with (time, the coil's or the target's temperature, the coil's rate).
They act where a slow change outside the target acts on the equivalent circuit: one set per frequency multiplies
the series inductance by (1 + sum_k c_k b_k) (a gain of the bridge need not be alike at every frequency), and one
set adds to the coil's parallel capacitance (water, a cable, the former's dielectric: one quantity at every
frequency, whose share of L differs between the coil in air and at the target and along x). The coefficients are
linear, with exact derivatives, and are fitted together with the model; a candidate is then judged beside them
(``search._beside_smooth``). Knots are evenly spaced over each variable's range (not at quantiles: a sweep's many
readings in a few minutes would otherwise get knots that follow x through time), at most ``KNOTS`` interior ones
and none closer than ``MIN_SPACING`` in that variable, so the smooth cannot follow a signature that changes within
a sweep (a lead screw's period in x, a backlash between directions). Where the smooth can follow a candidate's
signature (a moist former's drying, in the coil's temperature and time), the candidate gains nothing beside it and
is not claimed: an honest answer, not a miss. The simplest such nuisance, a straight line in time per frequency in L
alone (``linear_drift_effect``: a bridge's gain creeping), is what an effect a drift between sweeps can mimic must
stand beside (``checks.check_beyond_drift``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import numpy as np
from scipy.interpolate import BSpline

from ecds_lab.data.columns import VARIABLES
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import Effect, Inputs
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.model.tangents import InputTangents, Tangent, plus, scaled

#: The effect name of the nuisance (never in a registry the user sees; never claimed).
NAME = "outside_library_smooth"
#: Variables a smooth may be built in (the associations' names): slow, recorded quantities. Not x nor the
#: direction: the library's effects live there, and a smooth in x would take their signatures.
SMOOTHABLE = ("time_s", "t_coil_c", "t_target_c", "coil_rate_k_per_min")
#: At most this many interior knots per variable ...
KNOTS = 6
#: ... none closer than this in the variable's own unit (s, K, K, K/min): a sweep lasts minutes at one temperature.
MIN_SPACING: Mapping[str, float] = {"time_s": 1800.0, "t_coil_c": 5.0, "t_target_c": 5.0, "coil_rate_k_per_min": 0.2}
DEGREE = 3


def _knots(values: np.ndarray, spacing: float) -> np.ndarray | None:
    """The full knot vector of cubic B-splines over the range of ``values``, or None when the range is too short
    for a smooth (below one spacing: the variable is a constant there, an offset the baseline holds)."""
    finite = values[np.isfinite(values)]
    if len(finite) < 2:
        return None
    low, high = float(finite.min()), float(finite.max())
    if not high - low >= spacing:
        return None
    inner = min(KNOTS, int((high - low) // spacing) - 1)
    interior = np.linspace(low, high, inner + 2)
    return np.concatenate([[low] * DEGREE, interior, [high] * DEGREE])


def smooth_effect(data: Measurements, variables: Sequence[str]) -> type[Effect] | None:
    """A nuisance effect class (named ``NAME``) of cubic B-splines in ``variables`` per frequency of ``data``, with
    knots from ``data``'s ranges; None when no variable spans enough for a smooth."""
    splines = []
    for name in variables:
        if name not in SMOOTHABLE:
            continue
        knots = _knots(VARIABLES[name].values(data), MIN_SPACING[name])
        if knots is not None:
            splines.append((name, knots))
    if not splines:
        return None
    return _smooth_class(data, splines, DEGREE)


def linear_drift_effect(data: Measurements) -> type[Effect] | None:
    """A nuisance effect class (named ``NAME``) of a straight line in time per frequency of ``data``, in L alone: the
    slow drift every instrument has, at its simplest (a bridge's gain creeping with the hours); None when the
    readings span no time."""
    time_s = data.time_s[np.isfinite(data.time_s)]
    if len(time_s) < 2 or not float(np.ptp(time_s)) > 0:
        return None
    low, high = float(time_s.min()), float(time_s.max())
    return _smooth_class(data, [("time_s", np.array([low, low, high, high]))], 1, in_capacitance=False)


def _smooth_class(data: Measurements, splines: list[tuple[str, np.ndarray]], degree: int,
                  in_capacitance: bool = True) -> type[Effect]:
    """The nuisance class of B-splines of ``degree`` on the knots of ``splines`` (variable, full knot vector), per
    frequency of ``data``, and in the coil's capacitance unless not ``in_capacitance``."""
    frequencies = tuple(float(f) for f in np.unique(data.freq_hz))
    per_set = sum(len(knots) - degree - 1 for _, knots in splines)

    class Smooth(_Smooth):
        pass

    Smooth.degree = degree
    Smooth.splines = tuple(splines)
    Smooth.frequencies = frequencies
    Smooth.columns = per_set * len(frequencies)
    Smooth.capacitance_columns = per_set if in_capacitance else 0
    return Smooth


class _Smooth(Effect):
    """L_true times (1 + B c): B the splines in each variable, per frequency (see the module docstring)."""

    name = NAME
    explains = "a smooth relative change of L where the residual outside the library lives"
    tried_by_default = False
    splines: ClassVar[tuple[tuple[str, np.ndarray], ...]] = ()
    degree: ClassVar[int] = DEGREE
    frequencies: ClassVar[tuple[float, ...]] = ()
    columns: ClassVar[int] = 0
    capacitance_columns: ClassVar[int] = 0
    #: the data the splines were last made on (held, so its identity stays its own) and those splines
    _splined: tuple[Measurements, np.ndarray] | None = None

    def parameters(self) -> list[Parameter]:
        return [*(Parameter(f"smooth_{k}", 0.0, -0.1, 0.1, "1", "nuisance spline coefficient (relative L)", 1e-4)
                  for k in range(self.columns)),
                *(Parameter(f"smooth_c{k}", 0.0, -1e-9, 1e-9, "F", "nuisance spline coefficient (capacitance)",
                            1e-12) for k in range(self.capacitance_columns))]

    def splined(self, data: Measurements) -> np.ndarray:
        """The splines in every variable on ``data`` (values outside a spline's range held at its ends). Made once
        per data set: a fit evaluates the model, and asks for its L and its capacitance, on the same readings
        hundreds of times."""
        made = self._splined
        if made is not None and made[0] is data:
            return made[1]
        blocks = []
        for name, knots in self.splines:
            values = np.nan_to_num(VARIABLES[name].values(data), nan=knots[0])
            values = np.clip(values, knots[0], knots[-1])
            blocks.append(BSpline.design_matrix(values, knots, self.degree).toarray())
        self._splined = (data, np.hstack(blocks))
        return self._splined[1]

    def basis(self, data: Measurements) -> np.ndarray:
        """The n x columns design matrix of the relative change of L on ``data``: the splines per frequency."""
        splined = self.splined(data)
        return np.hstack([splined * (data.freq_hz == frequency)[:, None] for frequency in self.frequencies])

    def _factor(self, data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        basis = self.basis(data)
        coefficients = np.array([p[f"smooth_{k}"] for k in range(self.columns)])
        return basis, 1.0 + basis @ coefficients

    def coil_capacitance(self, c_f: np.ndarray, inputs: Inputs, data: Measurements,
                         p: Mapping[str, float]) -> np.ndarray:
        return c_f + self._added_capacitance(data, p)[1]

    def d_coil_capacitance(self, c_f: np.ndarray, dc: Tangent, inputs: Inputs, d_inputs: InputTangents,
                           data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        splined, added = self._added_capacitance(data, p)
        own = {f"smooth_c{k}": splined[:, k] for k in range(self.capacitance_columns)}
        return c_f + added, plus(dc, own)

    def _added_capacitance(self, data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        splined = self.splined(data)
        coefficients = np.array([p[f"smooth_c{k}"] for k in range(self.capacitance_columns)])
        return splined, splined[:, :self.capacitance_columns] @ coefficients

    def series_inductance(self, l_h: np.ndarray, inputs: Inputs, data: Measurements,
                          p: Mapping[str, float]) -> np.ndarray:
        return l_h * self._factor(data, p)[1]

    def d_series_inductance(self, l_h: np.ndarray, dl: Tangent, inputs: Inputs, d_inputs: InputTangents,
                            data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        basis, factor = self._factor(data, p)
        own = {f"smooth_{k}": l_h * basis[:, k] for k in range(self.columns)}
        return l_h * factor, plus(scaled(dl, factor), own)


def held_in_folds(model: SensorModel, values: Mapping[str, float]) -> dict[str, float]:
    """The nuisance smooth's coefficients in ``model`` at ``values``, to hold in held-out folds: fitted afresh
    without a block of time or temperature, a spline extrapolates into that block and the held-out error measures
    the spline, not the candidate; held at the fit on every reading (the same for the model with and without the
    candidate), the held-out error asks whether the candidate predicts what the smooth leaves."""
    return {p.name: values[p.name] for effect in model.effects if isinstance(effect, _Smooth)
            for p in effect.parameters()}
