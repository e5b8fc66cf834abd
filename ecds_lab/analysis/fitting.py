"""Least-squares fit of the sensor model to measurements: relative residuals in ppm of L.

Free parameters are scaled by their prior scale; the start comes from an analytic
guess (L0, alpha, beta by linear least squares on de-embedded readings of the coil in
air or far away); further starts are tried only when the first fit stays well above
the noise seen between repeated readings. Standard errors come from the Jacobian,
scaled by the residual variance. The noise of the readings is estimated once, by
``analysis.noise.estimate_noise`` on the final residuals (with the slide's declared repeatability
through the fitted model's sensitivity, where the data carry one), and carried by the result.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from ecds_lab.analysis.blas_threads import one_blas_thread
from ecds_lab.analysis.noise import REPEATED, NoiseEstimate, estimate_noise
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model import ecm
from ecds_lab.model.baseline import MIN_SPAN_ALPHA_K, MIN_SPAN_BETA_K
from ecds_lab.model.effects import Effect, EffectRegistry
from ecds_lab.model.parameters import Parameter, Scaling, update, values_of
from ecds_lab.model.sensor_model import SensorModel

#: A fit whose RMS exceeds this multiple of the repeat noise (plus a floor in ppm) gets more starts.
_RESTART_FACTOR, _RESTART_FLOOR_PPM = 3.0, 5.0
#: Without repeated readings to measure the noise, a fit above this RMS (ppm) gets more starts.
_RESTART_UNKNOWN_NOISE_PPM = 200.0
#: How many of the best grid points of the global stage are refined.
_RESTARTS = 3
#: The global stage scores its grid on at most this many readings (evenly spaced in the data):
#: enough to rank starts, and its cost stays flat as campaigns grow.
_GRID_ROWS = 4000


@dataclass
class FitResult:
    """Fitted parameters with standard errors, residuals in ppm of L and the figures of merit."""

    model: SensorModel
    parameters: list[Parameter]
    stderr: dict[str, float]
    fixed: dict[str, str]
    residuals_ppm: np.ndarray
    covariance: np.ndarray
    free_names: list[str]
    success: bool
    message: str
    nfev: int
    starts: int
    time_s: float
    #: noise of one reading, estimated from the fitted data and the residuals
    noise: NoiseEstimate

    @property
    def noise_ppm(self) -> float:
        """Noise of one reading (ppm of L) estimated from these data and residuals."""
        return self.noise.ppm

    @property
    def values(self) -> dict[str, float]:
        return values_of(self.parameters)

    @property
    def effects(self) -> list[str]:
        return self.model.effect_names

    @property
    def n(self) -> int:
        return len(self.residuals_ppm)

    @property
    def dof(self) -> int:
        return self.n - len(self.free_names)

    @property
    def rms_ppm(self) -> float:
        return float(np.sqrt(np.mean(self.residuals_ppm**2))) if self.n else math.nan

    @property
    def bic(self) -> float:
        """Bayesian information criterion with Gaussian residuals: n ln(RSS/n) + k ln n."""
        rss = float(np.sum(self.residuals_ppm**2))
        return self.n * math.log(max(rss, 1e-300) / self.n) + len(self.free_names) * math.log(self.n)

    def parameter(self, name: str) -> Parameter:
        return next(p for p in self.parameters if p.name == name)

    def predict(self, data: Measurements) -> np.ndarray:
        """Apparent Ls (H) the fitted model predicts for other data."""
        return self.model.predict(data, self.values)

    def params_table(self) -> dict[str, dict[str, float | str | None]]:
        """name -> {value, stderr, unit, fixed}: JSON-able (stderr None for fixed parameters)."""
        return {p.name: {"value": p.value, "stderr": None if p.fixed else _finite_or_none(self.stderr[p.name]),
                         "unit": p.unit, "fixed": p.fixed} for p in self.parameters}


def fit(data: Measurements, effects: Sequence[str | Effect] = (), sensor: SensorConfig | None = None, *,
        start: Mapping[str, float] | None = None, fixed: Mapping[str, float] | None = None,
        multistart: bool | None = None, registry: EffectRegistry | None = None) -> FitResult:
    """Fit the baseline plus named effects (from ``registry``, default the library) to measurements
    (keywords as for ``fit_model``)."""
    return fit_model(SensorModel(sensor, effects, registry=registry), data, start=start, fixed=fixed,
                     multistart=multistart)


def fit_model(model: SensorModel, data: Measurements, *, start: Mapping[str, float] | None = None,
              fixed: Mapping[str, float] | None = None, multistart: bool | None = None,
              rows: np.ndarray | None = None, screening: bool = False) -> FitResult:
    """Fit a model: parameters the data cannot determine and those in ``fixed`` are held constant.

    ``start`` overrides start values; ``multistart`` None tries more starts only when needed.
    ``rows`` (a boolean mask) fits only those rows while the model still runs over every row,
    so effects with a memory see the whole history (held-out validation uses this).
    ``screening`` stops at a relative cost change of 1e-8 and a smaller evaluation budget: enough
    to compare candidate models, without polishing a model that does not fit to the last digit.
    """
    if len(data) == 0:
        raise ValueError("no measurements to fit")
    began = time.perf_counter()
    reasons = {name: "fixed by the caller" for name in fixed or {}}
    for name, reason in model.unidentifiable(data).items():
        reasons.setdefault(name, reason)
    params = update(model.parameters(), fixed=fixed)
    params = [p.fix() if p.name in reasons and not p.fixed else p for p in params]
    params = update(params, values=initial_values(model, data, params))
    if start:
        params = update(params, values={k: v for k, v in start.items() if k not in reasons})
    fitted = data if rows is None else data.select(np.asarray(rows, bool))
    given = set(reasons) | set(start or {})  # an extension the caller fixed or started is not nested
    simpler = {name: value for effect in model.effects if not given & set(effect.simpler_form)
               for name, value in effect.simpler_form.items()}
    best, starts = _simpler_first(model, data, params, simpler, rows, screening)
    if multistart or (multistart is None and _needs_restart(best, _repeat_noise(fitted, best))):
        for candidate in _alternative_starts(model, data, params):
            result = _solve(model, data, candidate, rows, screening)
            starts += 1
            if result[0].cost < best[0].cost:
                best = result
    noise = _noise(model, fitted, best)
    return _result(model, data, best, reasons, noise, starts, time.perf_counter() - began)


def initial_values(model: SensorModel, data: Measurements, params: Sequence[Parameter]) -> dict[str, float]:
    """Analytic start for L0, alpha, beta: linear least squares on de-embedded air-coil inductances.

    Each reading is stripped of the parallel C and R_p, divided by (1 - k^2 f_T) at the start
    values, and the result fitted by L0 (1 + alpha dT + beta dT^2); coil-in-air rows are used
    when there are any (they do not depend on the calibration), else all rows; alpha and beta
    get a start only where those rows span enough temperature.
    """
    p = values_of(params)
    free = {q.name for q in params if not q.fixed}
    if "L0" not in free:
        return {}
    omega = 2 * np.pi * data.freq_hz
    z = data.rs_ohm + 1j * omega * data.ls_h
    series = 1.0 / (1.0 / z - 1j * omega * p["C_p"] - 1.0 / p["R_p"])
    k2 = model.coupling_hat(data.x_m, p) ** 2
    l_coil = series.imag / omega / (1 - k2 * ecm.eddy_factor(omega, p["tau_t"]))
    rows = data.in_air if data.in_air.any() else np.ones(len(data), bool)
    d = data.t_coil_c[rows] - model.sensor.reference_temperature_c
    span = float(np.ptp(d))
    needs = (("alpha", MIN_SPAN_ALPHA_K), ("beta", MIN_SPAN_BETA_K))
    names = [n for n, needed in needs if n in free and span >= needed]
    fixed_part = 1 + (0 if "alpha" in names else p["alpha"]) * d + (0 if "beta" in names else p["beta"]) * d**2
    columns = [fixed_part] + [d ** (1 + i) for i, n in enumerate(("alpha", "beta")) if n in names]
    coef, *_ = np.linalg.lstsq(np.column_stack(columns), l_coil[rows], rcond=None)
    if not np.isfinite(coef).all() or coef[0] <= 0:
        return {}
    return {"L0": float(coef[0]), **{n: float(c / coef[0]) for n, c in zip(names, coef[1:], strict=True)}}


def _noise(model: SensorModel, data: Measurements, solved: tuple[Any, Scaling]) -> NoiseEstimate:
    """The noise of a solution's readings: reading noise from its residuals, and the slide's declared
    repeatability through the fitted model's sensitivity where the data carry one."""
    sensitivity = None
    if (data.slide_repeatability_m > 0).any():
        sensitivity = model.relative_sensitivity(data, solved[1].values(solved[0].x))
    return estimate_noise(data, np.asarray(solved[0].fun, float), sensitivity)


def _repeat_noise(data: Measurements, solved: tuple[Any, Scaling]) -> float | None:
    """The noise (ppm) repeated readings show in a solution's residuals; None without repeats."""
    estimate = estimate_noise(data, np.asarray(solved[0].fun, float))
    return estimate.ppm if estimate.method == REPEATED else None


def _residual_function(model: SensorModel, data: Measurements, scaling: Scaling,
                       rows: np.ndarray | None = None) -> Callable[[np.ndarray], np.ndarray]:
    """theta -> relative residuals (measured / predicted - 1) in ppm, of ``rows`` if given."""
    measured = data.ls_h
    keep = slice(None) if rows is None else np.asarray(rows, bool)

    def residuals(theta: np.ndarray) -> np.ndarray:
        return ((measured / model.predict(data, scaling.values(theta)) - 1) * 1e6)[keep]

    return residuals


def _solve(model: SensorModel, data: Measurements, params: Sequence[Parameter],
           rows: np.ndarray | None = None, screening: bool = False) -> tuple[Any, Scaling]:
    """One local least-squares fit from the parameters' current values (theta = 0)."""
    scaling = Scaling(params)
    residuals = _residual_function(model, data, scaling, rows)
    if not scaling.names:
        r = residuals(np.zeros(0))
        return _Trivial(r), scaling
    lower, upper = scaling.bounds()
    theta0 = np.clip(np.zeros(len(scaling.names)), lower + 1e-9, upper - 1e-9)
    tolerance, budget = (1e-8, 15) if screening else (1e-12, 200)
    # The trust-region step factors the tall n x k Jacobian (cost linear in n); on one BLAS thread,
    # since threads only contend on a matrix this thin (``blas_threads``).
    with one_blas_thread():
        result = least_squares(residuals, theta0, bounds=(lower, upper), method="trf", x_scale=1.0,
                               ftol=tolerance, xtol=tolerance, gtol=tolerance, max_nfev=budget * (len(theta0) + 1))
    return result, scaling


def _simpler_first(model: SensorModel, data: Measurements, params: Sequence[Parameter], simpler: Mapping[str, float],
                   rows: np.ndarray | None, screening: bool) -> tuple[tuple[Any, Scaling], int]:
    """The local fit, nested where effects declare a simpler form (``Effect.simpler_form``): solved
    with those parameters held at it first, then with them free from their own start values and
    every other parameter at that solution; the better of the two (so never worse than the simpler
    law). Also the number of solves."""
    if not simpler:
        return _solve(model, data, params, rows, screening), 1
    first = _solve(model, data, update(params, fixed=simpler), rows, screening)
    result, scaling = first
    solution = {k: v for k, v in scaling.values(result.x).items() if k not in simpler}
    second = _solve(model, data, update(params, values=solution), rows, screening)
    return (second if second[0].cost <= result.cost else first), 2


class _Trivial:
    """Stand-in for a least_squares result when every parameter is fixed."""

    def __init__(self, residuals: np.ndarray) -> None:
        self.fun, self.x, self.jac = residuals, np.zeros(0), np.zeros((len(residuals), 0))
        self.cost, self.success, self.message, self.nfev = 0.5 * float(residuals @ residuals), True, "nothing free", 1


def _needs_restart(solved: tuple[Any, Scaling], noise: float | None) -> bool:
    """True when the fit failed or its RMS is well above the noise (a local minimum)."""
    result, _ = solved
    if not result.success:
        return True
    rms = math.sqrt(2 * result.cost / max(len(result.fun), 1))
    if noise is None:
        return rms > _RESTART_UNKNOWN_NOISE_PPM
    return rms > _RESTART_FACTOR * noise + _RESTART_FLOOR_PPM


def _alternative_starts(model: SensorModel, data: Measurements, params: Sequence[Parameter],
                        keep: int = _RESTARTS) -> list[list[Parameter]]:
    """Cheap global stage: the best few points of a grid over distance offset/scale and tau_T.

    These are where a local fit gets lost (Eq. 5's shift and stretch, the target's time
    constant); the grid is only evaluated, and the ``keep`` lowest-cost points become starts.
    """
    free = {p.name for p in params if not p.fixed}
    p = values_of(params)
    grid = {"p1": p["p1"] + np.linspace(-20e-3, 20e-3, 9), "p2": p["p2"] * np.array([0.7, 0.85, 1.0, 1.2, 1.4]),
            "tau_t": p["tau_t"] * np.array([0.1, 0.3, 1.0, 3.0, 10.0])}
    axes = {name: values for name, values in grid.items() if name in free}
    if not axes:
        return []
    scored = []
    stride = math.ceil(len(data) / _GRID_ROWS)
    sample = data if len(data) <= _GRID_ROWS else data.select(np.arange(0, len(data), stride))
    for combo in itertools.product(*axes.values()):
        changes = dict(zip(axes, combo, strict=True))
        candidate = update(params, values=changes)
        with np.errstate(all="ignore"):
            r = (sample.ls_h / model.predict(sample, values_of(candidate)) - 1) * 1e6
        cost = float(r @ r)
        if np.isfinite(cost) and any(candidate[i].value != params[i].value for i in range(len(params))):
            scored.append((cost, candidate))
    scored.sort(key=lambda item: item[0])
    return [candidate for _, candidate in scored[:keep]]


def _result(model: SensorModel, data: Measurements, solved: tuple[Any, Scaling], reasons: dict[str, str],
            noise: NoiseEstimate, starts: int, elapsed: float) -> FitResult:
    """Package the best solution: values, Jacobian standard errors, residuals."""
    result, scaling = solved
    values = scaling.values(result.x)
    params = update(scaling.parameters, values=values)
    residuals = np.asarray(result.fun, float)
    k = len(scaling.names)
    dof = len(residuals) - k
    covariance = _covariance(np.asarray(result.jac, float), residuals, dof) * np.outer(scaling.scale, scaling.scale)
    stderr = {p.name: math.nan for p in params}
    stderr.update(zip(scaling.names, np.sqrt(np.clip(np.diag(covariance), 0, None)).tolist(), strict=True))
    return FitResult(model, params, stderr, {n: reasons[n] for n in reasons}, residuals, covariance,
                     scaling.names, bool(result.success), str(result.message), int(result.nfev), starts,
                     elapsed, noise)


def _covariance(jac: np.ndarray, residuals: np.ndarray, dof: int) -> np.ndarray:
    """s^2 (J^T J)^-1 from the eigen-decomposition of the column-normalised k x k normal matrix (no SVD
    of the tall n x k Jacobian). Directions the data do not constrain give infinite variance to the
    parameters that take part in them, and only to those."""
    k = jac.shape[1]
    if k == 0:
        return np.zeros((0, 0))
    if dof <= 0:
        return np.full((k, k), np.inf)
    s2 = float(residuals @ residuals) / dof
    norms = np.sqrt(np.einsum("ij,ij->j", jac, jac))
    dead = ~(norms > 0)
    norms = np.where(dead, 1.0, norms)
    normal = (jac.T @ jac) / np.outer(norms, norms)
    eigenvalues, vectors = np.linalg.eigh(normal)
    top = eigenvalues.max(initial=0.0)
    tiny = eigenvalues <= top * 1e-14 if top > 0 else np.ones_like(eigenvalues, bool)
    kept = vectors[:, ~tiny]
    cov = (kept / eigenvalues[~tiny]) @ kept.T / np.outer(norms, norms)
    unconstrained = dead | (np.abs(vectors[:, tiny]) > 0.01).any(axis=1)
    cov[unconstrained, :] = np.inf
    cov[:, unconstrained] = np.inf
    return s2 * cov


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None
