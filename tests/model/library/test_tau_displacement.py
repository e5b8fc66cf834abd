"""tau_displacement: ln(tau_T / tau_T at 60 mm) is the natural cubic spline through its knot values, straight on from
20 and 100 mm to outer knots at 10 and 150 mm (each set by its bend beyond that straight line) and constant beyond
them (the 28 mm knot set by its bend beyond the straight line between 20 and 40 mm); it is worked out as the spline
through each unit vector of knot values, weighted by the values."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import Inputs
from ecds_lab.model.library.tau_displacement import FREE_KNOTS, TauDisplacement

KNOT_VALUES = {"tau_x_20mm": -0.4, "tau_bend_28mm": -0.25, "tau_x_40mm": -0.1, "tau_x_100mm": 0.3,
               "tau_bend_10mm": 0.0, "tau_bend_14mm": 0.0, "tau_bend_150mm": 0.0}
INNER_KNOTS_M = (0.020, 0.028, 0.040, 0.060, 0.100)


def _tau(effect: TauDisplacement, data, p) -> np.ndarray:
    inputs = Inputs(data.x_m, data.t_coil_c, data.t_target_c)
    return effect.target_tau(np.full(len(data), 2e-5), inputs, data, p)


def _inner_spline() -> CubicSpline:
    """The five-knot spline (20-100 mm) through KNOT_VALUES, written out from the module docstring."""
    values = [KNOT_VALUES["tau_x_20mm"], KNOT_VALUES["tau_bend_28mm"] + 0.6 * KNOT_VALUES["tau_x_20mm"]
              + 0.4 * KNOT_VALUES["tau_x_40mm"], KNOT_VALUES["tau_x_40mm"], 0.0, KNOT_VALUES["tau_x_100mm"]]
    return CubicSpline(INNER_KNOTS_M, values, bc_type="natural")


def test_the_time_constant_follows_the_natural_spline_through_the_knots_and_straight_on_beyond(readings_at):
    """With the outer bends nil (and the 14 mm one), the five-knot spline inside 20-100 mm, its straight continuation
    to 10 and 150 mm, constant beyond; the coil in air as at 60 mm."""
    effect = TauDisplacement(SensorConfig())
    positions_mm = np.r_[np.linspace(20.0, 100.0, 41), 12.0, 130.0, 5.0, 200.0, np.inf]
    data = readings_at(positions_mm)
    spline = _inner_spline()
    tau = _tau(effect, data, KNOT_VALUES)
    np.testing.assert_allclose(tau[:41], 2e-5 * np.exp(spline(positions_mm[:41] * 1e-3)), rtol=1e-12)
    straight = {x: spline(end) + spline(end, 1) * (x - end) for x, end in ((0.012, 0.020), (0.130, 0.100),
                                                                         (0.010, 0.020), (0.150, 0.100))}
    assert tau[41] == pytest.approx(2e-5 * np.exp(straight[0.012]), rel=1e-12)  # nearer than 20 mm: straight on
    assert tau[42] == pytest.approx(2e-5 * np.exp(straight[0.130]), rel=1e-12)  # beyond 100 mm
    assert tau[43] == pytest.approx(2e-5 * np.exp(straight[0.010]), rel=1e-12)  # nearer than 10 mm: as at 10 mm
    assert tau[44] == pytest.approx(2e-5 * np.exp(straight[0.150]), rel=1e-12)  # beyond 150 mm: as at 150 mm
    assert tau[45] == pytest.approx(2e-5, rel=1e-12)  # the coil in air: as at 60 mm


def test_a_bend_moves_its_knot_off_the_straight_line(readings_at):
    """The 10 mm bend off the continuation from 20 mm, the 14 mm one off the line between the 10 and 20 mm knots."""
    effect = TauDisplacement(SensorConfig())
    data = readings_at(np.array([10.0, 14.0, 60.0]))
    straight = _tau(effect, data, KNOT_VALUES)
    bent = _tau(effect, data, {**KNOT_VALUES, "tau_bend_10mm": 0.2})
    assert bent[0] / straight[0] == pytest.approx(np.exp(0.2), rel=1e-12)
    assert bent[1] / straight[1] == pytest.approx(np.exp(0.6 * 0.2), rel=1e-12)  # 14 mm: on the line to 20 mm
    assert bent[2] == pytest.approx(2e-5, rel=1e-12)
    nearest = _tau(effect, data, {**KNOT_VALUES, "tau_bend_14mm": -0.1})
    assert nearest[1] / straight[1] == pytest.approx(np.exp(-0.1), rel=1e-12)
    assert nearest[0] == pytest.approx(straight[0], rel=1e-12)


def test_new_knot_values_at_the_same_distances_give_their_own_spline(readings_at):
    """The spline's basis is kept for the distances; the knot values of each step still count."""
    effect = TauDisplacement(SensorConfig())
    data = readings_at(np.linspace(22.0, 90.0, 12))
    first = _tau(effect, data, KNOT_VALUES)
    doubled = _tau(effect, data, {name: 2 * value for name, value in KNOT_VALUES.items()})
    np.testing.assert_allclose(np.log(doubled / 2e-5), 2 * np.log(first / 2e-5), rtol=1e-12, atol=1e-15)


OUTER = {"tau_bend_10mm", "tau_bend_14mm", "tau_bend_150mm"}


@pytest.mark.parametrize(("positions_mm", "held"), [
    (np.linspace(20.0, 100.0, 9), OUTER),  # 10 mm apart: 30 mm between 20 and 40; none beyond 20-100 mm
    (np.r_[20.0, 40.0, 45.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0], {"tau_bend_28mm"} | OUTER),  # none between
    (np.linspace(20.0, 100.0, 7), set(FREE_KNOTS) - {"tau_x_20mm", "tau_x_40mm", "tau_x_100mm"}),  # seven
    (np.linspace(20.0, 100.0, 3), set(FREE_KNOTS)),  # too few positions for any knot
    (np.linspace(10.0, 100.0, 10), {"tau_bend_14mm", "tau_bend_150mm"}),  # one nearer than 20 mm: the 10 mm knot
    (np.linspace(11.0, 40.0, 9), {"tau_bend_150mm"}),  # 11, 14.6 and 18.2 mm: the 14 mm bend too
    (np.r_[8.0, 9.0, np.linspace(20.0, 100.0, 9)], {"tau_bend_14mm", "tau_bend_150mm"}),  # none between 10 and 20
    (np.linspace(20.0, 150.0, 14), {"tau_bend_10mm", "tau_bend_14mm"}),
])
def test_a_bend_needs_a_position_where_it_acts(readings_at, positions_mm, held):
    assert set(TauDisplacement(SensorConfig()).unidentifiable(readings_at(positions_mm))) == held


def test_a_fold_that_holds_out_every_reading_a_bend_acts_on_holds_it_straight(readings_at):
    """Its fit would leave the bend free (the held-out fit swung it to a bound: seed 2033 case 188)."""
    effect = TauDisplacement(SensorConfig())
    assert effect.held_out_of_reach(readings_at(np.r_[20.0, 40.0, 50.0, 60.0, 70.0])) == dict.fromkeys(
        {"tau_bend_28mm"} | OUTER, 0.0)
    assert effect.held_out_of_reach(readings_at(np.r_[12.0, 20.0, 30.0, 40.0, 120.0])) == {"tau_bend_14mm": 0.0}
    assert effect.held_out_of_reach(readings_at(np.r_[9.0, 12.0, 20.0, 30.0, 40.0, 120.0])) == {}


def test_a_straight_bend_puts_the_28_mm_knot_on_the_line(readings_at):
    effect = TauDisplacement(SensorConfig())
    data = readings_at(np.array([28.0]))
    p = {**KNOT_VALUES, "tau_bend_28mm": 0.0}
    assert _tau(effect, data, p)[0] == pytest.approx(2e-5 * np.exp(0.6 * -0.4 + 0.4 * -0.1), rel=1e-12)
