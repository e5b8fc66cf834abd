"""The reasons a candidate is rejected show a pure number without a unit: 'tau_x_100mm sits at its bound (3)',
not '(3 1)' (issue 24, point 7: parameters printed as '-2 1'); a unit is kept where there is one."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from ecds_lab.analysis.diagnosis.checks import identified, plausible_size


def _candidate(values: dict[str, float], units: dict[str, str], plausible: dict[str, tuple[float, float]]):
    params = {name: SimpleNamespace(name=name, value=v, unit=units[name], lower=-3.0, upper=3.0, fixed=False)
              for name, v in values.items()}
    effect = SimpleNamespace(key_names=lambda: tuple(values), size_names=lambda: tuple(values),
                             parameters=lambda: list(params.values()), plausible=plausible)
    fit = SimpleNamespace(parameter=params.__getitem__, values=dict(values), free_names=list(values),
                          covariance=np.full((len(values), len(values)), math.inf),
                          stderr={name: math.inf for name in values})
    return SimpleNamespace(effect_object=effect, fit=fit, effect="tau_displacement", fit_data=None)


def test_a_ratio_at_its_bound_and_out_of_its_range_has_no_unit_one():
    candidate = _candidate({"tau_x_100mm": 3.0, "tau_x_20mm": -2.855}, {"tau_x_100mm": "1", "tau_x_20mm": "1"},
                           {"tau_x_100mm": (-2.0, 2.0), "tau_x_20mm": (-2.0, 2.0)})
    _, bound = identified(candidate)
    _, size = plausible_size(candidate)
    assert "tau_x_100mm sits at its bound (3)" in bound
    assert "tau_x_20mm = -2.855 is outside the physically plausible -2..2" in size
    assert not any(" 1)" in r or r.endswith(" 1") or " 1 is" in r for r in bound + size), bound + size


def test_a_quantity_with_a_unit_keeps_it():
    candidate = _candidate({"lag_tau": 3.0}, {"lag_tau": "s"}, {"lag_tau": (-2.0, 2.0)})
    _, bound = identified(candidate)
    _, size = plausible_size(candidate)
    assert "lag_tau sits at its bound (3 s)" in bound
    assert "lag_tau = 3 s is outside the physically plausible -2..2 s" in size
