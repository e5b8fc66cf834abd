"""A key parameter's size is judged with the other parameters that sit on a bound held there: a fit that ran into
a wall is on an active constraint, not on a direction the data leave open (checks.held_at_bounds). Seen: a drying
of free water left the bound water's width on its bound, and its trade with the capacitance change made a drying
of 17 pF that took 1434 ppm to 126 ppm 'not determined'."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis.checks import held_at_bounds, identified

#: the size and a shape parameter correlated 0.995: alone the size is 1 standard error from zero, the shape held
#: the size's standard error is sqrt(1 - 0.995^2) = 0.0999
COVARIANCE = np.array([[1.0, 0.995], [0.995, 1.0]])


def _candidate(shape_value: float):
    params = {"size": SimpleNamespace(name="size", value=1.0, unit="F", lower=-10.0, upper=10.0, fixed=False),
              "shape": SimpleNamespace(name="shape", value=shape_value, unit="K", lower=1.0, upper=100.0,
                                       fixed=False)}
    effect = SimpleNamespace(key_names=lambda: ("size",), size_names=lambda: ("size",),
                             parameters=lambda: list(params.values()), plausible={})
    fit = SimpleNamespace(parameter=params.__getitem__, values={n: p.value for n, p in params.items()},
                          free_names=list(params), covariance=COVARIANCE, stderr={"size": 1.0, "shape": 1.0})
    return SimpleNamespace(effect_object=effect, fit=fit, effect="parasitic_capacitance", fit_data=None)


def test_a_shape_on_its_bound_is_held_there_when_the_size_is_judged():
    names, covariance = held_at_bounds(_candidate(100.0))
    assert names == ["size"]
    assert np.sqrt(covariance[0, 0]) == pytest.approx(np.sqrt(1 - 0.995**2))
    determined, why = identified(_candidate(100.0))
    assert determined, why


def test_a_shape_inside_its_range_still_trades_with_the_size():
    names, covariance = held_at_bounds(_candidate(50.0))
    assert names == ["size", "shape"] and covariance is COVARIANCE
    determined, why = identified(_candidate(50.0))
    assert not determined and "size is not determined" in why[0]
