"""Heated-coil readings built the paper's way (Section 5) from a room sweep and the coil heated in air."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.analysis.compensation import heated_coil_sweep, steady_coil_steps
from ecds_lab.simulators.campaign import coil_heated_sweeps, coil_heating, displacement_sweep
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

SETPOINTS = (50.0, 80.0, 120.0)


@pytest.fixture(scope="module")
def campaign():
    config = LabConfig(seed=3)
    lab = SimulatedLab(config)
    room = displacement_sweep(lab, positions_mm=np.linspace(20, 100, 9), directions=("forward",), air_repeats=5)
    heating = coil_heating(lab, setpoints_c=SETPOINTS, cool_down=False)
    hot = coil_heated_sweeps(lab, (SETPOINTS[-1],), positions_mm=np.linspace(20, 100, 9), directions=("forward",))
    return room, heating, hot


def test_steady_steps_are_room_and_each_set_point(campaign):
    _, heating, _ = campaign
    at_f = heating.select(heating.freq_hz == 500.0)
    steps = steady_coil_steps(at_f)
    means = [float(np.mean(at_f.t_coil_c[rows])) for rows in steps]
    assert means[0] < 25.0
    assert means[1:] == pytest.approx(list(SETPOINTS), abs=2.0)
    assert all(np.ptp(at_f.t_coil_c[rows]) <= 1.0 for rows in steps[1:])


def test_built_readings_match_a_sweep_with_the_coil_really_heated(campaign):
    room, heating, hot = campaign
    built = heated_coil_sweep(room, heating)
    assert np.isfinite(built.x_m).all() and set(built.frequencies_hz) == {500.0, 15000.0}
    assert len(built) == len(SETPOINTS) * 9 * 2  # every room reading at each steady temperature above room
    assert np.unique(np.round(built.t_coil_c[built.freq_hz == 500.0])) == pytest.approx(SETPOINTS, abs=2.0)
    for freq in (500.0, 15000.0):
        top = built.select((built.freq_hz == freq) & (built.t_coil_c > SETPOINTS[-1] - 5))
        real = hot.select(hot.freq_hz == freq)
        order_top, order_real = np.argsort(top.x_m), np.argsort(real.x_m)
        np.testing.assert_allclose(top.x_m[order_top], real.x_m[order_real])
        relative = top.ls_h[order_top] / real.ls_h[order_real] - 1
        assert np.max(np.abs(relative)) < 150e-6  # bridge noise of two readings and the L||C cross term


def test_nothing_is_built_without_a_steady_step_above_room(campaign):
    room, heating, _ = campaign
    cold = heating.select(heating.t_coil_c < 25.0)
    assert len(heated_coil_sweep(room, cold)) == 0
