"""Least-squares fit of the sensor model to measurements: relative residuals in ppm of L.

Free parameters are scaled by their prior scale; the start comes from an analytic
guess (L0, alpha, beta by linear least squares on de-embedded readings of the coil in
air or far away); further starts are tried only when the first fit stays well above
the noise seen between repeated readings (on a campaign of more than ``_SEARCH_ROWS`` readings, solved
on a random subsample of that many, and only a start that wins there polished on every reading).
Standard errors come from the Jacobian, scaled by the residual variance. The noise of the readings is estimated once, by
``analysis.noise.estimate_noise`` on the final residuals (with the slide's positioning scatter
through the fitted model's sensitivity), and carried by the result.

The error model is an option (``fit_model(noise=..., robust=...)``): with a ``NoiseEstimate`` each
residual is weighed by that estimate's typical noise over the reading's own (``NoiseEstimate.sigma_ppm``),
so a noisy phase counts less; ``robust`` replaces the squares by Huber's loss beyond ``ROBUST_SIGMAS``
noise sigmas, so a single wild reading (a glitch the rules missed) pulls a parameter, and the cost, only
linearly. The robust fit is iteratively reweighted least squares (weighted refits from the plain solution,
each reading weighted min(1, c/|r|), until the weights settle): scipy's own ``loss="huber"``
took 4-5x as long on a 240-reading sweep (its trust region creeps along the kink).
``FitResult.effective_residuals_ppm`` are the residuals whose sum of squares is that cost (to compare
models fitted the same way). ``FitResult.clustered(labels)`` gives cluster-robust standard errors
(``analysis.cluster_errors``).
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from ecds_lab.analysis.blas_threads import one_blas_thread
from ecds_lab.analysis.cluster_errors import cluster_robust_covariance
from ecds_lab.analysis.heap import retain_freed_memory
from ecds_lab.analysis.noise import REPEATED, NoiseEstimate, estimate_noise
from ecds_lab.analysis.subsample import screened
from ecds_lab.analysis.tall_svd import tall_svd
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
#: Campaigns larger than this try their alternative starts on a random subsample of this many readings
#: (``_restarts_on_sample``), and polish on every reading only a start that wins there by ``_SEARCH_GAIN`` of the cost.
_SEARCH_ROWS = 20_000
#: How far inside its bound (in units of its prior scale) a polish starts a parameter that starts on it (``_solve``).
_INSIDE_BOUND = 1e-3
#: A screening polish (a solution on a subsample refitted on every reading) stops after this many evaluations per
#: free parameter and one: it starts near the answer, and a polish still going after them is crawling along a curved
#: valley. The bending claim of a 10^6-reading faithful campaign took 5.26 million of its chi-square in its first 25
#: evaluations and 38,000 (0.7 %) in the next 365, which cost 566 s; at this budget it stops 23,000 above that end
#: (0.1 % of the model's chi-square; the claim's gain is 5 million). At 10^5 readings no polish comes near it.
_POLISH_BUDGET = 4
#: A polish told the noise (``fit_model``'s ``noise_ppm``) also stops at the first step that gains less than this in
#: chi-square, in units of that noise's variance: a tenth of one reading's variance decides nothing the diagnosis
#: weighs (its evidence needs 25). A relative cost change of 1e-8 asks for 0.01 at 10^5 readings left at 4x the
#: noise, three more evaluations of every reading in some polishes there.
NEGLIGIBLE_CHI2 = 0.1
_SEARCH_GAIN = 1e-6
#: Huber's loss turns from squares to linear this many noise sigmas out (Gaussian efficiency ~99 %; a
#: reading 20 sigmas out then pulls a parameter 10x less than under squares).
ROBUST_SIGMAS = 2.0
#: Reweighted refits of a robust fit (each from the last solution) until no weight changes by more than
#: the tolerance: two or three from a plain fit near the answer, more when glitches bent it far off.
IRLS_ROUNDS = 12
IRLS_TOLERANCE = 0.02


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
    #: noise of one reading, estimated from the fitted data and the residuals (``noise``): the estimate, or a
    #: function that makes it when first asked for
    noise_estimate: NoiseEstimate | Callable[[], NoiseEstimate]
    #: each fitted reading's weight (typical noise / its own) when fitted with an error model, else None
    weights: np.ndarray | None = None
    #: where Huber's loss turns linear (ppm, of the weighted residual) when fitted robustly, else None
    loss_scale_ppm: float | None = None
    #: d residual / d parameter (ppm per unit, weighted as fitted) of the free parameters at the solution
    jacobian: np.ndarray | None = None

    @property
    def noise(self) -> NoiseEstimate:
        """Noise of one reading, estimated from the fitted data and the residuals (made on first use)."""
        if not isinstance(self.noise_estimate, NoiseEstimate):
            self.noise_estimate = self.noise_estimate()
        return self.noise_estimate

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

    @property
    def effective_residuals_ppm(self) -> np.ndarray:
        """Residuals as the fit weighed them: times the weights, and through Huber's loss when robust
        (sign(r) c sqrt(rho((r/c)^2)): their sum of squares is twice the cost minimised); the plain
        residuals for a plain fit. Chi-square comparisons of models fitted alike use these."""
        r = self.residuals_ppm if self.weights is None else self.residuals_ppm * self.weights
        return r if self.loss_scale_ppm is None else huber_residuals(r, self.loss_scale_ppm)

    def clustered(self, labels: np.ndarray) -> FitResult:
        """This fit with cluster-robust (sandwich) standard errors and covariance, clusters ``labels`` per
        fitted reading (e.g. ``grouping.visit_labels``): readings of one cluster may share an error."""
        if self.jacobian is None:
            raise ValueError("this fit kept no Jacobian: cluster-robust errors need one")
        cov = cluster_robust_covariance(self.jacobian, self.effective_residuals_ppm, np.asarray(labels))
        stderr = {p.name: math.nan for p in self.parameters}
        stderr.update(zip(self.free_names, np.sqrt(np.clip(np.diag(cov), 0, None)).tolist(), strict=True))
        return dataclasses.replace(self, stderr=stderr, covariance=cov)

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
              rows: np.ndarray | None = None, screening: bool = False, noise: NoiseEstimate | None = None,
              robust: bool = False, polish: bool = False, noise_ppm: float | None = None,
              budget: int | None = None) -> FitResult:
    """Fit a model: parameters the data cannot determine and those in ``fixed`` are held constant.

    ``start`` overrides start values; ``multistart`` None tries more starts only when needed.
    ``rows`` (a boolean mask) fits only those rows while the model still runs over every row,
    so effects with a memory see the whole history (held-out validation uses this).
    ``screening`` stops at a relative cost change of 1e-8 and a smaller evaluation budget: enough
    to compare candidate models, without polishing a model that does not fit to the last digit.
    ``noise`` weighs each residual by ``noise.ppm / noise.sigma_ppm(data)``; ``robust`` (needs ``noise``)
    uses Huber's loss beyond ``ROBUST_SIGMAS`` x ``noise.ppm`` (module docstring).
    ``polish``: ``start`` is this model's solution on other readings of the campaign (a subsample), near the answer,
    so the solver's first trust region is not confined by a parameter starting on its bound (``_solve``); with
    ``screening``, it stops after ``_POLISH_BUDGET`` evaluations per parameter, and with ``noise_ppm`` (one reading's
    noise, ppm) at a step gaining less than ``NEGLIGIBLE_CHI2`` in that noise's variance.
    ``budget``: evaluations per free parameter and one the solver may take (default: 15 screening, 200 otherwise,
    ``_POLISH_BUDGET`` polishing), for a fit that only ranks starts (a repolish's scout).
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
    terms = _error_terms(data, rows, noise, robust)
    given = set(reasons) | set(start or {})  # an extension the caller fixed or started is not nested
    simpler = {name: value for effect in model.effects if not given & set(effect.simpler_form)
               for name, value in effect.simpler_form.items()}
    best, starts = _simpler_first(model, data, params, simpler, rows, screening, terms, polish, noise_ppm, budget)
    if multistart or (multistart is None and _needs_restart(best, _repeat_noise(fitted, best))):
        alternatives = _alternative_starts(model, data, params)
        if rows is None and terms.weights is None and len(data) > _SEARCH_ROWS:
            best, more = _restarts_on_sample(model, data, best, alternatives, screening)
            starts += more
        else:
            for candidate in alternatives:
                result = _solve(model, data, candidate, rows, screening, terms)
                starts += 1
                if result[0].cost < best[0].cost:
                    best = result
    if terms.loss_scale_ppm is not None:
        best, terms = _reweighted(model, data, best, rows, screening, terms)
    # The noise is estimated when first asked for: most fits of a diagnosis's search (candidates, held-out folds,
    # alternative starts) never ask, and its estimate cost 5 % of a 10^5-reading diagnosis.
    # It keeps the solution's values and residuals only (not the solver's result and its Jacobian).
    estimate = functools.partial(_noise, model, fitted, best[1].values(best[0].x), np.asarray(best[0].fun, float),
                                 terms)
    return _result(model, data, best, reasons, estimate, starts, time.perf_counter() - began, terms)


def evaluated(result: FitResult, data: Measurements, *, noise_anew: bool = False) -> FitResult:
    """``result``'s solution on other readings (a screening subsample), not refitted: its residuals there; its
    noise stays the fit's own, or with ``noise_anew`` is estimated on these readings' residuals (made on first use)."""
    residuals = (data.ls_h / result.predict(data) - 1) * 1e6
    noise = functools.partial(_noise, result.model, data, result.values, residuals) if noise_anew \
        else result.noise_estimate
    return dataclasses.replace(result, residuals_ppm=residuals, nfev=0, starts=0, time_s=0.0, weights=None,
                               loss_scale_ppm=None, jacobian=None, noise_estimate=noise)


def referenced(data: Measurements, model: SensorModel) -> tuple[object, ...]:
    """What a fit of ``model`` to ``data`` refers to that a forked worker should send back as the caller's own
    (``forked.each``): the data, and the classes of the model's effects (a nuisance smooth's class is made at run
    time, so it cannot be pickled by name)."""
    return (data, *(type(effect) for effect in model.effects))


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


@dataclass(frozen=True)
class _ErrorTerms:
    """How residuals are weighed: per-row noise weights of the fitted rows, Huber's scale (None: squares) and
    the reweighting's current sqrt(min(1, c/|r|)) per row (None before the first round)."""

    weights: np.ndarray | None = None
    loss_scale_ppm: float | None = None
    reweighting: np.ndarray | None = None

    @property
    def solve_weights(self) -> np.ndarray | None:
        """What the residual function multiplies its residuals by."""
        if self.reweighting is None:
            return self.weights
        return self.reweighting if self.weights is None else self.weights * self.reweighting

    def plain(self, fun: np.ndarray) -> np.ndarray:
        """The unweighted residuals (ppm) behind a solution's weighted ones."""
        w = self.solve_weights
        return np.asarray(fun, float) if w is None else np.asarray(fun, float) / w

    def noise_weighted(self, fun: np.ndarray) -> np.ndarray:
        """A solution's residuals weighted by the noise only (what Huber's loss is applied to)."""
        r = self.plain(fun)
        return r if self.weights is None else r * self.weights


def _reweighted(model: SensorModel, data: Measurements, solved: tuple[Any, Scaling], rows: np.ndarray | None,
                screening: bool, terms: _ErrorTerms) -> tuple[tuple[Any, Scaling], _ErrorTerms]:
    """Huber's loss by iteratively reweighted least squares from a plain solution (module docstring): refits
    until no reading's weight changes by more than ``IRLS_TOLERANCE`` (at most ``IRLS_ROUNDS``)."""
    scale = terms.loss_scale_ppm
    previous = None
    for _ in range(IRLS_ROUNDS if scale is not None else 0):
        result, scaling = solved
        z = np.abs(terms.noise_weighted(result.fun))
        reweighting = np.sqrt(np.minimum(1.0, scale / np.maximum(z, 1e-300)))
        if previous is not None and np.max(np.abs(reweighting - previous)) < IRLS_TOLERANCE:
            break
        terms, previous = dataclasses.replace(terms, reweighting=reweighting), reweighting
        solved = _solve(model, data, update(scaling.parameters, values=scaling.values(result.x)), rows, screening,
                        terms)
    return solved, terms


def _error_terms(data: Measurements, rows: np.ndarray | None, noise: NoiseEstimate | None,
                 robust: bool) -> _ErrorTerms:
    """The fit's error terms from an error model (see ``fit_model``)."""
    if noise is None:
        if robust:
            raise ValueError("a robust fit needs a noise estimate (noise=...): Huber's scale is in noise sigmas")
        return _ErrorTerms()
    sigma = noise.sigma_ppm(data)
    weights = np.where(sigma > 0, noise.ppm / np.where(sigma > 0, sigma, 1.0), 1.0)
    if rows is not None:
        weights = weights[np.asarray(rows, bool)]
    return _ErrorTerms(weights, ROBUST_SIGMAS * noise.ppm if robust and noise.ppm > 0 else None)


def huber_residuals(r: np.ndarray, scale: float) -> np.ndarray:
    """Residuals through Huber's loss (scipy's rho(z) = z, or 2 sqrt(z) - 1 beyond z = 1, of z = (r/c)^2):
    sign(r) c sqrt(rho), whose squares sum to the robust cost (twice scipy's ``cost``)."""
    z = (np.asarray(r, float) / scale) ** 2
    rho = np.where(z <= 1, z, 2 * np.sqrt(z) - 1)
    return np.sign(r) * scale * np.sqrt(rho)


def _noise(model: SensorModel, data: Measurements, values: Mapping[str, float], residuals: np.ndarray,
           terms: _ErrorTerms = _ErrorTerms(), beside_sweeps: bool = False) -> NoiseEstimate:
    """The noise of a solution's readings (its parameter ``values`` and residuals as solved): reading noise from
    its (unweighted) residuals, and the slide's positioning scatter through the fitted model's sensitivity where
    the coil faces the target; ``beside_sweeps`` as for ``estimate_noise``."""
    sensitivity = None
    if np.isfinite(data.x_m).any():
        sensitivity = model.relative_sensitivity(data, values)
    return estimate_noise(data, terms.plain(residuals), sensitivity, beside_sweeps=beside_sweeps)


def noise_of(result: FitResult, data: Measurements, *, beside_sweeps: bool = False) -> NoiseEstimate:
    """The noise of ``result``'s readings ``data`` estimated anew from its residuals (``_noise``), with
    ``estimate_noise``'s ``beside_sweeps``."""
    return _noise(result.model, data, result.values, result.residuals_ppm, beside_sweeps=beside_sweeps)


def _repeat_noise(data: Measurements, solved: tuple[Any, Scaling]) -> float | None:
    """The noise (ppm) repeated readings show in a solution's residuals; None without repeats."""
    estimate = estimate_noise(data, np.asarray(solved[0].fun, float))
    return estimate.ppm if estimate.method == REPEATED else None


def _residual_function(model: SensorModel, data: Measurements, scaling: Scaling,
                       rows: np.ndarray | None = None, weights: np.ndarray | None = None
                       ) -> Callable[[np.ndarray], np.ndarray]:
    """theta -> relative residuals (measured / predicted - 1) in ppm, of ``rows`` if given, times ``weights``."""
    measured = data.ls_h
    keep = slice(None) if rows is None else np.asarray(rows, bool)
    weight = 1.0 if weights is None else weights

    def residuals(theta: np.ndarray) -> np.ndarray:
        return ((measured / model.predict(data, scaling.values(theta)) - 1) * 1e6)[keep] * weight

    return residuals


def _first_known(residuals: Callable[[np.ndarray], np.ndarray], theta0: np.ndarray, first: np.ndarray
                 ) -> Callable[[np.ndarray], np.ndarray]:
    """``residuals`` answering its first call at ``theta0`` with ``first``, already computed (the solver's first
    evaluation, every reading's, made once)."""
    known = [first]

    def answered(theta: np.ndarray) -> np.ndarray:
        if known and np.array_equal(theta, theta0):
            return known.pop()
        known.clear()
        return residuals(theta)

    return answered


#: Rows of the Jacobian filled at a time (``_jacobian_function``): 4,096 x 30 parameters is 1 MB.
_JACOBIAN_BLOCK = 4096


def _jacobian_function(model: SensorModel, data: Measurements, scaling: Scaling,
                       rows: np.ndarray | None = None, weights: np.ndarray | None = None) -> Callable[..., np.ndarray]:
    """theta -> the exact Jacobian of ``_residual_function`` (n x free parameters, the same ``rows`` and
    ``weights``), from the model's analytic derivatives: d/d theta_j (m / L - 1) 1e6 = -1e6 m / L^2 dL/dp_j scale_j."""
    measured = data.ls_h
    keep = slice(None) if rows is None else np.asarray(rows, bool)
    weight = 1.0 if weights is None else weights
    zero = np.zeros(len(data))

    def jacobian(theta: np.ndarray, *_: Any) -> np.ndarray:
        predicted, tangent = model.prediction_and_jacobian(data, scaling.values(theta), scaling.names)
        factor = (-1e6 * measured / predicted**2)[keep] * weight
        if len(factor) <= _JACOBIAN_BLOCK:  # one block (a screen): every parameter at once, the same products
            stacked = np.array([tangent.get(name, zero)[keep] for name in scaling.names]).reshape(
                len(scaling.names), len(factor))
            np.multiply(stacked, np.asarray(scaling.scale)[:, None] * factor, out=stacked)
            return np.ascontiguousarray(stacked.T)
        # Filled by blocks of rows: each block parameter by parameter into contiguous rows of a small buffer that
        # stays in the processor's cache, then transposed into the result (C order: the solver's sums run as they
        # always have). Writing each column of the n x k result in place strides through memory (4x as long at
        # 10^5 readings); one k x n buffer transposed whole passes over memory twice more (a third of a 10^6-reading
        # claim's refit).
        columns = [(tangent.get(name, zero)[keep], scale)
                   for name, scale in zip(scaling.names, scaling.scale, strict=True)]
        out = np.empty((len(factor), len(columns)))
        buffer = np.empty((len(columns), _JACOBIAN_BLOCK))
        for start in range(0, len(factor), _JACOBIAN_BLOCK):
            block = slice(start, min(start + _JACOBIAN_BLOCK, len(factor)))
            size = block.stop - block.start
            for row, (values, scale) in enumerate(columns):
                np.multiply(values[block], factor[block] * scale, out=buffer[row, :size])
            out[block] = buffer[:, :size].T
        return out

    return jacobian


def _solve(model: SensorModel, data: Measurements, params: Sequence[Parameter],
           rows: np.ndarray | None = None, screening: bool = False,
           terms: _ErrorTerms = _ErrorTerms(), polish: bool = False, noise_ppm: float | None = None,
           budget: int | None = None) -> tuple[Any, Scaling]:
    """One local least-squares fit from the parameters' current values (theta = 0); ``polish`` and ``noise_ppm`` as
    for ``fit_model``."""
    scaling = Scaling(params)
    residuals = _residual_function(model, data, scaling, rows, terms.solve_weights)
    if not scaling.names:
        r = residuals(np.zeros(0))
        return _Trivial(r), scaling
    lower, upper = scaling.bounds()
    # scipy's trf sizes its first trust region from the start's distance to the bounds: a parameter starting 1e-9
    # inside its bound made it 3e-5, and a polish from a nearby solution spent half its evaluations growing it. A
    # polish starts such a parameter _INSIDE_BOUND of its scale inside. Other fits keep the near-bound start: from
    # an effect's defaults the larger first steps settled a drying in other valleys (validation study: fewer found).
    inside = np.minimum(_INSIDE_BOUND if polish else 1e-9, 0.25 * (upper - lower))
    theta0 = np.clip(np.zeros(len(scaling.names)), lower + inside, upper - inside)
    tolerance, default_budget = (1e-8, _POLISH_BUDGET if polish else 15) if screening else (1e-12, 200)
    budget = default_budget if budget is None else budget
    cost_tolerance = tolerance
    if polish and noise_ppm and screening:  # trf stops at a step gaining less than ftol x the cost before it
        first = residuals(theta0)
        residuals = _first_known(residuals, theta0, first)
        cost_tolerance = max(tolerance, NEGLIGIBLE_CHI2 * noise_ppm**2 / float(first @ first))
    # The exact Jacobian where every effect gives its derivatives (one pass of the model per Jacobian, against one
    # per free parameter for finite differences); otherwise scipy's finite differences.
    jac = _jacobian_function(model, data, scaling, rows, terms.solve_weights) if model.has_derivatives else "2-point"
    retain_freed_memory()  # the model's arrays are reused between evaluations, not faulted in anew (``heap``)
    # The trust-region step factors the tall n x k Jacobian (cost linear in n); on one BLAS thread,
    # since threads only contend on a matrix this thin (``blas_threads``), and through its QR (``tall_svd``).
    with one_blas_thread(), tall_svd():
        result = least_squares(residuals, theta0, jac=jac, bounds=(lower, upper), method="trf", x_scale=1.0,
                               ftol=cost_tolerance, xtol=tolerance, gtol=tolerance, max_nfev=budget * (len(theta0) + 1))
    return result, scaling


def _simpler_first(model: SensorModel, data: Measurements, params: Sequence[Parameter], simpler: Mapping[str, float],
                   rows: np.ndarray | None, screening: bool,
                   terms: _ErrorTerms = _ErrorTerms(), polish: bool = False, noise_ppm: float | None = None,
                   budget: int | None = None) -> tuple[tuple[Any, Scaling], int]:
    """The local fit, nested where effects declare a simpler form (``Effect.simpler_form``): solved
    with those parameters held at it first, then with them free from their own start values and
    every other parameter at that solution; the better of the two (so never worse than the simpler
    law). Also the number of solves. ``polish`` and ``noise_ppm`` as for ``fit_model``."""
    if not simpler:
        return _solve(model, data, params, rows, screening, terms, polish, noise_ppm, budget), 1
    first = _solve(model, data, update(params, fixed=simpler), rows, screening, terms, polish, noise_ppm, budget)
    result, scaling = first
    solution = {k: v for k, v in scaling.values(result.x).items() if k not in simpler}
    second = _solve(model, data, update(params, values=solution), rows, screening, terms, polish, noise_ppm, budget)
    return (second if second[0].cost <= result.cost else first), 2


class _Trivial:
    """Stand-in for a least_squares result when every parameter is fixed."""

    def __init__(self, residuals: np.ndarray) -> None:
        self.fun, self.x, self.jac = residuals, np.zeros(0), np.zeros((len(residuals), 0))
        self.cost, self.success, self.message, self.nfev = 0.5 * float(residuals @ residuals), True, "nothing free", 1


def _restarts_on_sample(model: SensorModel, data: Measurements, best: tuple[Any, Scaling],
                        alternatives: Sequence[Sequence[Parameter]],
                        screening: bool) -> tuple[tuple[Any, Scaling], int]:
    """The global stage of a large campaign: every alternative start solved on a random subsample of
    ``_SEARCH_ROWS`` readings beside the first solution polished there, and only a start that ends clearly lower
    there (by ``_SEARCH_GAIN`` of the cost) polished on every reading, kept if lower there too. Which valley is
    deepest shows on tens of thousands of readings as on all; a full solve per start cost seconds at 10^5 readings
    and minutes at 10^6. Also the number of solves."""
    sample = screened(data, _SEARCH_ROWS)
    result, scaling = best
    incumbent = _solve(model, sample, update(scaling.parameters, values=scaling.values(result.x)), None, screening)
    winner = incumbent
    for candidate in alternatives:
        trial = _solve(model, sample, candidate, None, screening)
        if trial[0].cost < winner[0].cost:
            winner = trial
    solves = 1 + len(alternatives)
    if winner is incumbent or not winner[0].cost < (1 - _SEARCH_GAIN) * incumbent[0].cost:
        return best, solves
    trial_result, trial_scaling = winner
    polished = _solve(model, data, update(trial_scaling.parameters, values=trial_scaling.values(trial_result.x)),
                      None, screening, polish=True)
    return (polished if polished[0].cost < result.cost else best), solves + 1


def _needs_restart(solved: tuple[Any, Scaling], noise: float | None) -> bool:
    """True when the fit failed or its RMS is well above the noise (a local minimum)."""
    result, _ = solved
    if not result.success:
        return True
    rms = math.sqrt(float(np.mean(np.square(result.fun)))) if len(result.fun) else 0.0
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
            noise: NoiseEstimate | Callable[[], NoiseEstimate], starts: int, elapsed: float,
            terms: _ErrorTerms = _ErrorTerms()) -> FitResult:
    """Package the best solution: values, Jacobian standard errors, residuals (unweighted)."""
    result, scaling = solved
    values = scaling.values(result.x)
    params = update(scaling.parameters, values=values)
    weighted = terms.noise_weighted(result.fun)
    effective = weighted if terms.loss_scale_ppm is None else huber_residuals(weighted, terms.loss_scale_ppm)
    residuals = terms.plain(result.fun)
    k = len(scaling.names)
    dof = len(residuals) - k
    jacobian = np.asarray(result.jac, float)
    covariance = _covariance(jacobian, effective, dof) * np.outer(scaling.scale, scaling.scale)
    stderr = {p.name: math.nan for p in params}
    stderr.update(zip(scaling.names, np.sqrt(np.clip(np.diag(covariance), 0, None)).tolist(), strict=True))
    return FitResult(model, params, stderr, {n: reasons[n] for n in reasons}, residuals, covariance,
                     scaling.names, bool(result.success), str(result.message), int(result.nfev), starts,
                     elapsed, noise, terms.weights, terms.loss_scale_ppm,
                     jacobian / np.asarray(scaling.scale, float) if k else jacobian)


@dataclass(frozen=True)
class _NormalEigen:
    """The column-normalised k x k normal matrix of a Jacobian, eigen-decomposed: its directions the data
    constrain (``kept``) and those they leave open (``tiny``, relative eigenvalue <= 1e-14; a column of zeros is
    ``dead``)."""

    norms: np.ndarray
    dead: np.ndarray
    eigenvalues: np.ndarray
    vectors: np.ndarray
    tiny: np.ndarray

    @classmethod
    def of(cls, jac: np.ndarray) -> _NormalEigen:
        norms = np.sqrt(np.einsum("ij,ij->j", jac, jac))
        dead = ~(norms > 0)
        norms = np.where(dead, 1.0, norms)
        eigenvalues, vectors = np.linalg.eigh((jac.T @ jac) / np.outer(norms, norms))
        top = eigenvalues.max(initial=0.0)
        tiny = eigenvalues <= top * 1e-14 if top > 0 else np.ones_like(eigenvalues, bool)
        return cls(norms, dead, eigenvalues, vectors, tiny)


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
    e = _NormalEigen.of(jac)
    kept = e.vectors[:, ~e.tiny]
    with np.errstate(over="ignore", invalid="ignore"):  # a column all but dead (norm ~1e-160): its variance is inf
        cov = (kept / e.eigenvalues[~e.tiny]) @ kept.T / np.outer(e.norms, e.norms)
    unconstrained = e.dead | (np.abs(e.vectors[:, e.tiny]) > 0.01).any(axis=1) | ~np.isfinite(np.diag(cov))
    cov[unconstrained, :] = np.inf
    cov[:, unconstrained] = np.inf
    return s2 * cov


def combination_stderr(fit: FitResult, gradient: Mapping[str, float]) -> float:
    """Standard error of sum_i g_i p_i over the fit's free parameters (``gradient``: g by name): finite whenever
    the data determine the combination, even where they leave its parameters open one by one (an estimable
    function: g has no share in a direction the data leave open; a share above 1 % of it gives inf). Judging
    the combination itself, not the per-parameter covariance, keeps the answer from flipping with rounding
    when a direction it does not use sits at the rank threshold."""
    g = np.array([gradient.get(name, 0.0) for name in fit.free_names], float)
    if not g.any():
        return math.inf
    if fit.jacobian is None or fit.dof <= 0:
        with np.errstate(invalid="ignore", over="ignore"):
            variance = float(g @ fit.covariance @ g)
        return math.sqrt(variance) if math.isfinite(variance) and variance >= 0 else math.inf
    e = _NormalEigen.of(fit.jacobian)
    if (g[e.dead] != 0).any():
        return math.inf
    with np.errstate(over="ignore", invalid="ignore"):  # a gradient on an all but dead column (norm ~1e-160): inf
        scaled = g / e.norms
        along = e.vectors.T @ scaled
        if not np.isfinite(along).all() or float(along[e.tiny] @ along[e.tiny]) > 1e-4 * float(scaled @ scaled):
            return math.inf
        effective = fit.effective_residuals_ppm
        s2 = float(effective @ effective) / fit.dof
        variance = s2 * float(np.sum(along[~e.tiny] ** 2 / e.eigenvalues[~e.tiny]))
    return math.sqrt(variance) if math.isfinite(variance) else math.inf


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None
