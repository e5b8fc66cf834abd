"""An effect's size judged as a whole (issue 26, case c): the knots of tau_T(x) each trade with the baseline along one
direction while the curve is known, and a bending's linear and quadratic terms trade when the sweeps see two
temperatures while the shift they make is known; two effects that each take a different part of the residual (a
backlash the difference between the directions, tau_T(x) the difference between the frequencies) are no
alternatives."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from ecds_lab.analysis.diagnosis.checks import identified, joint_wald
from ecds_lab.analysis.diagnosis.result import Candidate
from ecds_lab.analysis.diagnosis.search import _rival, overlap


def _fitted(values: dict[str, float], covariance: np.ndarray, size: tuple[str, ...] = (),
            keys: tuple[str, ...] | None = None) -> SimpleNamespace:
    params = {name: SimpleNamespace(name=name, value=v, unit="1", lower=-3.0, upper=3.0, fixed=False)
              for name, v in values.items()}
    key_names = tuple(values) if keys is None else keys
    effect = SimpleNamespace(name="curve", key_names=lambda: key_names, size_names=lambda: size or key_names,
                             parameters=lambda: list(params.values()), plausible={})
    stderr = dict(zip(values, np.sqrt(np.diag(covariance)).tolist(), strict=True))
    fit = SimpleNamespace(parameter=params.__getitem__, values=dict(values), free_names=list(values),
                          covariance=covariance, stderr=stderr)
    return SimpleNamespace(effect_object=effect, fit=fit, effect="curve", fit_data=None)


def _common_direction(n: int, loose: float, tight: float) -> np.ndarray:
    """A covariance with one loose direction (every parameter together) and the rest tight."""
    common = np.ones(n) / math.sqrt(n)
    return loose**2 * np.outer(common, common) + tight**2 * (np.eye(n) - np.outer(common, common))


def test_knots_each_undetermined_but_jointly_far_from_flat_are_identified():
    # the numbers of case (c)'s start: knots 0.15, 0.16, 0.13 and -0.44, each +-1 to 1.7, the shape known to 0.02
    values = {"k20": 0.15, "k28": 0.16, "k40": 0.13, "k100": -0.44}
    candidate = _fitted(values, _common_direction(4, 1.5, 0.02))
    assert all(abs(v) < 3 * candidate.fit.stderr[k] for k, v in values.items())
    assert joint_wald(candidate, tuple(values)) > 100.0
    determined, why = identified(candidate)
    assert determined, why


def test_knots_jointly_within_their_errors_are_not_identified():
    values = {"k20": 0.01, "k28": -0.02, "k40": 0.015, "k100": 0.0}
    candidate = _fitted(values, _common_direction(4, 1.5, 0.02))
    determined, why = identified(candidate)
    assert not determined and "jointly as well" in why[0], why


def test_a_size_in_two_terms_that_trade_is_judged_by_the_shift_they_make():
    # b1 and b2 of a bending, each within 1 standard error, correlated -0.999: b1 + b2 dT_hot is known
    values = {"bending": -3.1e-6, "bending_quadratic": 6.3e-8}
    s1, s2, rho = 3.8e-6, 6.3e-8, -0.9995
    covariance = np.array([[s1**2, rho * s1 * s2], [rho * s1 * s2, s2**2]])
    alone = _fitted(values, covariance, keys=("bending",))
    assert not identified(alone)[0]
    both = _fitted(values, covariance, size=("bending", "bending_quadratic"), keys=("bending",))
    determined, why = identified(both)
    assert determined, why


class _Readings:
    """Stands for the readings a candidate was fitted to: only their number is asked."""

    def __init__(self, rows: int) -> None:
        self.rows = rows

    def __len__(self) -> int:
        return self.rows


def _step(residuals: np.ndarray) -> SimpleNamespace:
    """Stands for the current step: its residuals on the candidates' readings (not a screened campaign's)."""
    return SimpleNamespace(fit=SimpleNamespace(residuals_ppm=residuals), on_screen=None)


def _explaining(name: str, residuals: np.ndarray, data: object, gain: float) -> Candidate:
    fit = SimpleNamespace(residuals_ppm=residuals)
    return Candidate(name, fit, -30.0, -30.0, gain, checks={"evidence": True, "identifiable": True,  # type: ignore[arg-type]
                                                             "plausible": True, "held_out": True}, fit_data=data)


def test_two_effects_taking_different_parts_of_the_residual_are_no_rivals():
    rows = 40
    data = _Readings(rows)
    noise = SimpleNamespace(ppm=20.0, sigma_ppm=lambda d: np.full(rows, 20.0))
    directions = np.where(np.arange(rows) < 20, 1.0, 0.0) * np.resize([100.0, -100.0], rows)
    frequencies = np.where(np.arange(rows) >= 20, 1.0, 0.0) * np.linspace(-100.0, 100.0, rows)
    before = directions + frequencies
    backlash = _explaining("slide_backlash", before - directions, data, 50.0)
    tau_x = _explaining("tau_displacement", before - frequencies, data, 46.0)
    current = _step(before)
    assert overlap(backlash, tau_x, current, noise) < 0.01  # type: ignore[arg-type]
    assert not _rival(backlash, tau_x, current, noise)  # type: ignore[arg-type]
    alike = _explaining("target_tau_temperature", before - 0.9 * directions, data, 46.0)
    assert overlap(backlash, alike, current, noise) > 0.99  # type: ignore[arg-type]
    assert _rival(backlash, alike, current, noise)  # type: ignore[arg-type]
