"""Fits with the exact Jacobian find what finite differences find, with fewer model evaluations per step."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.analysis import fitting
from ecds_lab.analysis.fitting import fit_model
from ecds_lab.model.sensor_model import SensorModel


@pytest.mark.parametrize("effects", [("target_bending",), ("thermal_lag", "target_tau_temperature")])
def test_exact_and_finite_difference_jacobians_reach_the_same_fit(campaign_with, monkeypatch: pytest.MonkeyPatch,
                                                                   effects: tuple[str, ...]) -> None:
    data = campaign_with(*effects)
    exact = fit_model(SensorModel(effects=list(effects)), data)
    monkeypatch.setattr(SensorModel, "has_derivatives", property(lambda self: False))
    calls = []
    real = fitting._jacobian_function
    monkeypatch.setattr(fitting, "_jacobian_function", lambda *a, **k: calls.append(1) or real(*a, **k))
    numeric = fit_model(SensorModel(effects=list(effects)), data)
    assert not calls  # the finite-difference fit did not touch the analytic Jacobian
    assert exact.rms_ppm <= numeric.rms_ppm * (1 + 1e-9)  # at least as far down: no worse than differences
    assert exact.rms_ppm == pytest.approx(numeric.rms_ppm, rel=1e-6)
    for name in exact.free_names:  # the same solution, far inside its uncertainty (a flat valley leaves a little)
        assert exact.values[name] == pytest.approx(numeric.values[name], abs=0.02 * exact.stderr[name]), name
        assert exact.stderr[name] == pytest.approx(numeric.stderr[name], rel=0.02), name
    assert np.isfinite(exact.covariance).all()
