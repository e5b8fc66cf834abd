"""Named parameters, their scaling for the fit, and which ones the data can determine."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.baseline import baseline_parameters, baseline_unidentifiable
from ecds_lab.model.parameters import Parameter, Scaling, update, values_of


def test_parameter_checks_bounds_and_scale():
    with pytest.raises(ValueError, match="lower bound"):
        Parameter("a", 1.0, 2.0, 1.0)
    with pytest.raises(ValueError, match="prior_scale"):
        Parameter("a", 1.0, prior_scale=0.0)
    assert Parameter("a", 0.0, -1.0, 1.0).with_value(5.0).value == 1.0


def test_update_sets_and_fixes_by_name_and_rejects_unknown_names():
    params = baseline_parameters(SensorConfig())
    out = update(params, values={"L0": 0.06}, fixed={"alpha": 1e-5})
    got = {p.name: p for p in out}
    assert got["L0"].value == 0.06 and not got["L0"].fixed
    assert got["alpha"].fixed and got["alpha"].value == 1e-5
    with pytest.raises(ValueError, match="gamma"):
        update(params, values={"gamma": 1.0})


def test_scaling_round_trips_and_skips_fixed_parameters():
    params = baseline_parameters(SensorConfig())
    scaling = Scaling(params)
    assert "R_p" not in scaling.names and "L0" in scaling.names
    theta = np.linspace(-1, 1, len(scaling.names))
    values = scaling.values(theta)
    np.testing.assert_allclose(scaling.theta(values), theta, atol=1e-9)
    assert values["R_p"] == values_of(params)["R_p"]
    lower, upper = scaling.bounds()
    assert np.all(lower < 0) and np.all(upper > 0)


def _rows(x_m, freq_hz, t_coil_c) -> Measurements:
    n = len(x_m)
    return Measurements(np.arange(n, dtype=float), np.asarray(x_m, float), np.asarray(freq_hz, float),
                        np.asarray(t_coil_c, float), np.full(n, 22.0), np.ones(n), np.ones(n))


def test_room_temperature_sweep_at_one_frequency_fixes_what_it_cannot_see():
    x = np.r_[np.linspace(0.02, 0.1, 31), np.inf]
    fixed = baseline_unidentifiable(_rows(x, np.full(32, 15e3), np.full(32, 22.0)))
    assert {"alpha", "beta", "C_p", "tau_t", "R_p"} == set(fixed)
    assert "span" in fixed["alpha"]


def test_coil_in_air_heating_fixes_the_calibration():
    t = np.linspace(22, 120, 40)
    fixed = baseline_unidentifiable(_rows(np.full(40, np.inf), np.tile([500.0, 15e3], 20), t))
    assert {"p1", "p2", "p3", "p4", "tau_t", "R_p"} == set(fixed)


def test_few_positions_release_calibration_parameters_with_one_to_spare():
    x = np.r_[[0.02, 0.028, 0.036, 0.044], np.inf]
    fixed = baseline_unidentifiable(_rows(x, np.full(5, 15e3), np.full(5, 22.0)))
    assert "p4" in fixed and not {"p1", "p2", "p3"} & set(fixed)
    fixed = baseline_unidentifiable(_rows(x[:4], np.full(4, 15e3), np.full(4, 22.0)))
    assert {"p2", "p4"} <= set(fixed) and not {"p1", "p3"} & set(fixed)


def test_moderate_span_fits_alpha_but_not_beta():
    t = np.linspace(22, 40, 10)
    fixed = baseline_unidentifiable(_rows(np.full(10, np.inf), np.full(10, 500.0), t))
    assert "beta" in fixed and "alpha" not in fixed
