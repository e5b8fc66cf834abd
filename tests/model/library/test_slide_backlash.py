"""slide_backlash: the slide stops short by half its backlash on the side it came from; it is testable only where
positions were approached from both sides under the same conditions."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.library.slide_backlash import SlideBacklash


@pytest.fixture
def backlash() -> SlideBacklash:
    return SlideBacklash(SensorConfig())


UP = [20.0, 30.0, 40.0, 50.0]


def test_the_slide_stops_short_on_the_side_it_came_from(backlash, readings_at):
    data = readings_at(UP + UP[::-1], [1] * 4 + [-1] * 4)
    moved = backlash.effective_distance(data.x_m, data, {"backlash": 20e-6})
    np.testing.assert_allclose((moved - data.x_m) * 1e6, [-10.0] * 4 + [10.0] * 4)


def test_sweeps_both_ways_at_the_same_temperatures_test_it(backlash, readings_at):
    assert backlash.unidentifiable(readings_at(UP + UP[::-1], [1] * 4 + [-1] * 4)) == {}
    # at room temperature either side of a bin's edge (22 C) the temperatures are the same all the same
    edge = readings_at(UP + UP[::-1], [1] * 4 + [-1] * 4, t_coil_c=[21.99] * 4 + [22.01] * 4,
                      t_target_c=[22.02] * 4 + [21.98] * 4)
    assert backlash.unidentifiable(edge) == {}


def test_one_direction_leaves_it_untestable(backlash, readings_at):
    assert "one direction only" in backlash.unidentifiable(readings_at(UP, 1))["backlash"]


def test_the_two_sides_at_different_temperatures_leave_it_untestable(backlash, readings_at):
    """A sweep up at room temperature, then down to 20 mm only to start a run with the target at 75 C: 20 mm is
    approached from both sides, but at different temperatures, where a plate bending nearer reads as play
    (validation study seed 2028, case 44)."""
    data = readings_at(UP + UP, [1, 1, 1, 1, -1, 1, 1, 1], t_target_c=[22.0] * 4 + [75.0] * 4)
    assert "0 position(s) approached from both directions" in backlash.unidentifiable(data)["backlash"]
    both = readings_at(UP + UP[::-1] + UP, [1] * 4 + [-1] * 4 + [1] * 4, t_target_c=[22.0] * 8 + [75.0] * 4)
    assert backlash.unidentifiable(both) == {}  # the room-temperature sweeps both ways tell it
