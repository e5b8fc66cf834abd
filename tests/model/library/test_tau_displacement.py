"""tau_displacement: ln(tau_T / tau_T at 60 mm) is the natural cubic spline through its knot values, constant beyond
the knots (the 28 mm knot set by its bend beyond the straight line between 20 and 40 mm); it is worked out as the
spline through each unit vector of knot values, weighted by the values."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import Inputs
from ecds_lab.model.library.tau_displacement import FREE_KNOTS, KNOTS_M, TauDisplacement

KNOT_VALUES = {"tau_x_20mm": -0.4, "tau_bend_28mm": -0.25, "tau_x_40mm": -0.1, "tau_x_100mm": 0.3}


def _tau(effect: TauDisplacement, data, p) -> np.ndarray:
    inputs = Inputs(data.x_m, data.t_coil_c, data.t_target_c)
    return effect.target_tau(np.full(len(data), 2e-5), inputs, data, p)


def test_the_time_constant_follows_the_natural_spline_through_the_knots_and_stays_constant_beyond(readings_at):
    effect = TauDisplacement(SensorConfig())
    positions_mm = np.r_[np.linspace(20.0, 100.0, 41), 12.0, 150.0, np.inf]
    data = readings_at(positions_mm)
    values = np.zeros(len(KNOTS_M))
    for name, index in FREE_KNOTS.items():
        values[index] = KNOT_VALUES[name]
    values[1] += 0.6 * KNOT_VALUES["tau_x_20mm"] + 0.4 * KNOT_VALUES["tau_x_40mm"]  # 28 mm: its bend beyond the line
    spline = CubicSpline(KNOTS_M, values, bc_type="natural")
    tau = _tau(effect, data, KNOT_VALUES)
    np.testing.assert_allclose(tau[:41], 2e-5 * np.exp(spline(positions_mm[:41] * 1e-3)), rtol=1e-12)
    assert tau[41] == pytest.approx(2e-5 * np.exp(KNOT_VALUES["tau_x_20mm"]), rel=1e-12)  # nearer than 20 mm
    assert tau[42] == pytest.approx(2e-5 * np.exp(KNOT_VALUES["tau_x_100mm"]), rel=1e-12)  # beyond 100 mm
    assert tau[43] == pytest.approx(2e-5, rel=1e-12)  # the coil in air: as at 60 mm


def test_new_knot_values_at_the_same_distances_give_their_own_spline(readings_at):
    """The spline's basis is kept for the distances; the knot values of each step still count."""
    effect = TauDisplacement(SensorConfig())
    data = readings_at(np.linspace(22.0, 90.0, 12))
    first = _tau(effect, data, KNOT_VALUES)
    doubled = _tau(effect, data, {name: 2 * value for name, value in KNOT_VALUES.items()})
    np.testing.assert_allclose(np.log(doubled / 2e-5), 2 * np.log(first / 2e-5), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(("positions_mm", "held"), [
    (np.linspace(20.0, 100.0, 9), set()),  # 10 mm apart: 30 mm between 20 and 40
    (np.r_[20.0, 40.0, 45.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0], {"tau_bend_28mm"}),  # none between: straight there
    (np.linspace(20.0, 100.0, 7), set(FREE_KNOTS)),  # too few positions for any knot
])
def test_the_bend_at_28_mm_needs_a_position_between_20_and_40_mm(readings_at, positions_mm, held):
    assert set(TauDisplacement(SensorConfig()).unidentifiable(readings_at(positions_mm))) == held


def test_a_fold_that_holds_out_every_reading_between_20_and_40_mm_holds_the_bend_straight(readings_at):
    """Its fit would leave the bend free (the held-out fit swung it to a bound: seed 2033 case 188)."""
    effect = TauDisplacement(SensorConfig())
    assert effect.held_out_of_reach(readings_at(np.r_[20.0, 40.0, 50.0, 60.0, 70.0])) == {"tau_bend_28mm": 0.0}
    assert effect.held_out_of_reach(readings_at(np.r_[20.0, 30.0, 40.0, 50.0])) == {}


def test_a_straight_bend_puts_the_28_mm_knot_on_the_line(readings_at):
    effect = TauDisplacement(SensorConfig())
    data = readings_at(np.array([28.0]))
    p = {**KNOT_VALUES, "tau_bend_28mm": 0.0}
    assert _tau(effect, data, p)[0] == pytest.approx(2e-5 * np.exp(0.6 * -0.4 + 0.4 * -0.1), rel=1e-12)
