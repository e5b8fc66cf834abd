"""What these data can tell, decided from the data: the Jacobian of the model's prediction.

Two questions, both answered by projecting one Jacobian column out of others (readings weighed by
their noise):

- Is a baseline parameter the rules fix (``baseline_unidentifiable``: tau_T at one frequency, C_p...)
  determined after all? Its column, with the calibration's columns (below) projected out, gives the
  standard error a fit would reach; below half its value the parameter is released (``released``),
  and kept free only if the fit confirms that standard error. (The fit's residuals are those of Ls:
  at one frequency Ls alone ties tau_T to the coupling's gain exactly, so tau_T is released there only
  once the loss holds what else determines it, e.g. Rs.)
- Is an effect's signature absorbed by the calibration? A real calibration follows any smooth change
  of the coupling with distance, shared by every frequency (the coil and plate are one); so the
  calibration's space is the current model's free columns plus ``s(row) B_j(x)``: a cubic B-spline
  basis in x times the reading's response to the squared coupling (d ln L / d ln k^2). An effect whose
  key parameters' columns keep less than ``ABSORBED_SHARE`` of their norm after that projection moves
  nothing these data could tell from a calibration (at one frequency a change of tau_T with distance
  is one; at two it is not, the two frequencies respond to it differently): it is ``untestable`` here,
  unless the effect's start is the size its physics predicts (``Effect.absent_form``) and that predicted
  action keeps more than ``MIN_CHI2_GAIN`` noise variances after the projection, or is too large for a
  projection at the current solution to judge (``BEYOND_LINEAR``): a thick plate's millimetre of extra
  set-back at 500 Hz is, to first order, a tau_T change and a smooth calibration, but the fit with it moves
  tau_T to its bound and leaves the noise where the baseline left ten times it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.interpolate import BSpline

from ecds_lab.analysis.diagnosis.checks import MIN_CHI2_GAIN
from ecds_lab.analysis.diagnosis.result import ABSORBED_WORDS
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import GIVEN_BY_SENSOR, Effect, EffectRegistry
from ecds_lab.model.parameters import Parameter, values_of
from ecds_lab.model.sensor_model import SensorModel

#: The calibration's form the final residual is judged beside (``beyond_calibration``): 6 cubic B-splines, two inner
#: knots, smooth on the scale of a third of the range. With 8 (the testability check's) a metal object's bump of 15 mm
#: full width, read every 4 mm at one frequency, was taken as well; with 6 it stays outside the library, while the
#: broad misfit of a sensor Eq. (5) does not follow (a steel plate over 9 positions, a 30 mm coil at 500 Hz) is taken.
FORM_BASIS = 6
#: A key parameter whose column keeps less than this share of its norm after the projection is absorbed.
ABSORBED_SHARE = 0.1
#: Baseline parameters the rules may fix that the data can still determine (positive by nature).
RELEASABLE = ("tau_t", "C_p")
#: A parameter is determined when its standard error is below this share of its value.
DETERMINED_SHARE = 0.5
#: A predicted action with an RMS beyond this many noise sigmas is judged by its fit, not by a projection.
BEYOND_LINEAR = 100.0
#: Cubic B-spline functions of the calibration's smooth change of the coupling with x (at most).
CALIBRATION_BASIS = 8


class ReleasedModel(SensorModel):
    """A sensor model whose ``released`` baseline parameters are free although its rules would fix them:
    the data were found to determine them (``releasable``)."""

    def __init__(self, sensor: SensorConfig | None, effects: Sequence[str | Effect], registry: EffectRegistry,
                 released: frozenset[str] = frozenset()) -> None:
        super().__init__(sensor, effects, registry=registry)
        self.released = released

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        return {k: v for k, v in super().unidentifiable(data).items() if k not in self.released}


def _log_prediction(model: SensorModel, data: Measurements, values: Mapping[str, float]) -> np.ndarray:
    with np.errstate(all="ignore"):
        return np.log(model.predict(data, values))


def columns(model: SensorModel, data: Measurements, values: Mapping[str, float], names: Sequence[str],
            steps: Mapping[str, float]) -> np.ndarray:
    """d ln Ls / d parameter (ppm per unit of the parameter) at ``values``: central differences of ``steps``."""
    out = np.zeros((len(data), len(names)))
    for j, name in enumerate(names):
        step = steps[name]
        up = _log_prediction(model, data, {**values, name: values[name] + step})
        down = _log_prediction(model, data, {**values, name: values[name] - step})
        out[:, j] = np.nan_to_num((up - down) / (2 * step) * 1e6)
    return out


def _steps(parameters: Sequence[Parameter]) -> dict[str, float]:
    return {p.name: 0.1 * p.prior_scale for p in parameters}


def _project_out(basis: np.ndarray, target: np.ndarray) -> np.ndarray:
    """``target``'s columns minus their least-squares fit by ``basis``'s columns."""
    if basis.shape[1] == 0:
        return target
    scale = np.linalg.norm(basis, axis=0)
    usable = scale > 0
    if not usable.any():
        return target
    b = basis[:, usable] / scale[usable]
    coef, *_ = np.linalg.lstsq(b, target, rcond=1e-10)
    return target - b @ coef


def calibration_basis(model: SensorModel, data: Measurements, values: Mapping[str, float],
                      functions: int = CALIBRATION_BASIS) -> np.ndarray:
    """s(row) B_j(x): smooth changes of the coupling with distance, shared by every frequency (see the
    module docstring), at most ``functions`` of them; none for the coil in air or with too few distinct positions."""
    finite = np.isfinite(data.x_m)
    positions = np.unique(np.round(data.x_m[finite], 6))
    count = min(functions, len(positions) - 1)
    if count < 4:
        return np.zeros((len(data), 0))
    gain = max(abs(values["p3"]), 1e-6)
    response = columns(model, data, values, ["p3"], {"p3": 1e-4 * gain})[:, 0] * gain / 2.0  # d ln L / d ln k^2
    inner = np.quantile(positions, np.linspace(0, 1, count - 2))[1:-1]
    low, high = positions[0], positions[-1]
    knots = np.r_[[low] * 4, inner, [high] * 4]
    x = np.clip(np.where(finite, data.x_m, low), low, high)
    basis = BSpline.design_matrix(x, knots, 3).toarray()
    return np.where(finite[:, None], basis * response[:, None], 0.0)


def calibration_space(model: SensorModel, data: Measurements, values: Mapping[str, float], free: Sequence[str],
                      noise: NoiseEstimate, held: Sequence[str] = ()) -> np.ndarray:
    """The columns a calibration can follow (weighed by each reading's noise): the current model's free
    parameters and the smooth change of the coupling with x (``calibration_basis``), then those of the ``held``
    nuisance parameters (``held_nuisances``), last. One per round."""
    steps = _steps(model.parameters())
    block = np.hstack([columns(model, data, values, list(free), steps), calibration_basis(model, data, values),
                       columns(model, data, values, list(held), steps)])
    return block * _weights(data, noise)


def held_nuisances(model: SensorModel, data: Measurements) -> list[str]:
    """The nuisance parameters of ``model``'s acting effects (a key parameter free) that these data leave it holding
    (``unidentifiable``) at a value nothing gives: what a candidate explains only through that value is no evidence
    for it (at one frequency the drying's swelling is held at 0, and an expansion would take its strain of the
    coupling). A value the sensor description gives (a plate's thickness, ``GIVEN_BY_SENSOR``) is known, not open."""
    held = model.unidentifiable(data)
    return [name for effect in model.effects if not set(effect.key_names()) <= set(held)
            for name in effect.nuisance_parameters if name in held and held[name] != GIVEN_BY_SENSOR]


def _weights(data: Measurements, noise: NoiseEstimate) -> np.ndarray:
    return (noise.ppm / noise.sigma_ppm(data))[:, None] if noise.ppm > 0 else np.ones((len(data), 1))


def beyond_calibration(model: SensorModel, data: Measurements, values: Mapping[str, float], residuals_ppm: np.ndarray,
                       noise: NoiseEstimate) -> np.ndarray | None:
    """The residual once a smooth calibration curve in x (``calibration_basis``, readings weighed by their noise)
    took what it can, at one frequency with the target present (at two the curve is one shape for both and
    cannot take what differs between them); None elsewhere, or with too few positions for the curve."""
    finite = np.isfinite(data.x_m)
    if len(np.unique(data.freq_hz[finite])) != 1:
        return None
    basis = calibration_basis(model, data, values, FORM_BASIS)
    if basis.shape[1] == 0:
        return None
    weights = _weights(data, noise)
    left = _project_out(basis * weights, np.asarray(residuals_ppm, float)[:, None] * weights)
    return left[:, 0] / weights[:, 0]


def absorbed(model: SensorModel, data: Measurements, values: Mapping[str, float], space: np.ndarray,
             noise: NoiseEstimate, held: Sequence[str] = ()) -> str | None:
    """Why the last effect of ``model`` is untestable here (its signature absorbed by ``space``, the
    ``calibration_space`` of the current model with the ``held`` nuisance parameters' columns last), or None.
    The reason names the held parameters where without them the signature would not be absorbed.

    ``values``: the current solution with the effect's own parameters at their starts."""
    effect = model.effects[-1]
    own = effect.parameters()
    keys = list(effect.key_names())
    target = columns(model, data, values, keys, _steps(own)) * _weights(data, noise)
    norms = np.linalg.norm(target, axis=0)
    if not (norms > 0).any():
        return "its signature moves none of these readings"

    def share_left(columns_of: np.ndarray) -> float:
        left = np.linalg.norm(_project_out(columns_of, target), axis=0)
        return float(np.max(np.divide(left, norms, out=np.zeros_like(left), where=norms > 0)))

    share = share_left(space)
    if share >= ABSORBED_SHARE or _predicted_action_visible(model, data, values, space, noise):
        return None
    by_held = bool(held) and share_left(space[:, :-len(held)]) >= ABSORBED_SHARE
    beside = "".join(f", the held {name}" for name in held) if by_held else ""
    return (f"its signature is {ABSORBED_WORDS} in these data (after the baseline{beside} and a smooth "
            f"calibration curve in x take what they can, {share:.0%} of it is left)")


def _predicted_action_visible(model: SensorModel, data: Measurements, values: Mapping[str, float],
                              space: np.ndarray, noise: NoiseEstimate) -> bool:
    """True when the last effect's predicted action (its start against its ``absent_form``) keeps more than
    MIN_CHI2_GAIN noise variances (design effect applied) once ``space`` takes what it can, or is so large
    (RMS beyond BEYOND_LINEAR x the noise) that a projection at the current solution cannot judge it: the fit
    with it moves far (a millimetre of set-back at 500 Hz sends tau_T from 1.2 ms to its bound), and its own
    standard errors decide, as for every candidate."""
    absent = model.effects[-1].absent_form
    if not absent or not noise.ppm > 0:
        return False
    action = (_log_prediction(model, data, values) - _log_prediction(model, data, {**values, **absent})) * 1e6
    weighted = np.nan_to_num(action)[:, None] * _weights(data, noise)
    if float(np.sqrt(np.mean(weighted**2))) > BEYOND_LINEAR * noise.ppm:
        return True
    left = _project_out(space, weighted)
    return float(np.sum(left**2)) / noise.ppm**2 / noise.design_effect > MIN_CHI2_GAIN


def releasable(model: SensorModel, data: Measurements, values: Mapping[str, float], free: Sequence[str],
               fixed: Mapping[str, str], noise: NoiseEstimate) -> list[str]:
    """Baseline parameters the rules fixed (``fixed``) that these data determine: the standard error their
    column reaches beside the free ones is below DETERMINED_SHARE of their value."""
    names = [n for n in RELEASABLE if n in fixed and n not in {"R_p"} and abs(values.get(n, 0.0)) > 0]
    if not names or not noise.ppm > 0:
        return []
    weights = (1.0 / noise.sigma_ppm(data))[:, None]
    steps = _steps(model.parameters())
    target = columns(model, data, values, names, steps) * weights
    base = calibration_space(model, data, values, free, noise) / noise.ppm  # a calibration takes its share first
    left = np.linalg.norm(_project_out(base, target), axis=0)
    out = []
    for name, information in zip(names, left, strict=True):
        stderr = math.sqrt(noise.design_effect) / information if information > 0 else math.inf
        if stderr < DETERMINED_SHARE * abs(values[name]):
            out.append(name)
    return out


def start_values(model: SensorModel, current: Mapping[str, float]) -> dict[str, float]:
    """Every parameter of ``model``: the current solution where it has one, the start value otherwise."""
    return {**values_of(model.parameters()), **{k: v for k, v in current.items()}}
