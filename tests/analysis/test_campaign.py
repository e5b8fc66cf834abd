"""Simulated campaigns: what the paper measured, as Measurements, quickly."""

from __future__ import annotations

import math
import time

import numpy as np

from ecds_lab.simulators.campaign import (
    PAPER_POSITIONS_MM,
    coil_heating,
    displacement_sweep,
    paper_campaign,
    target_heating,
)
from ecds_lab.simulators.config import Effects, LabConfig, SlideBacklash
from ecds_lab.simulators.lab import BOX_HEATER_OUTPUT, TARGET_HEATER_OUTPUT, SimulatedLab


def test_paper_campaign_covers_the_experiments_quickly():
    began = time.perf_counter()
    data = paper_campaign(LabConfig(), seed=1)
    elapsed = time.perf_counter() - began
    assert elapsed < 3.0
    assert 1000 <= len(data) <= 3000
    assert np.all(np.diff(data.time_s) > 0) and set(data.segment) == {0}
    assert set(data.frequencies_hz) == {500.0, 15000.0}
    finite = np.isfinite(data.x_m)
    assert data.in_air.sum() > 100 and finite.sum() > 400
    np.testing.assert_allclose(np.unique(np.round(data.x_mm[finite], 6)), PAPER_POSITIONS_MM)
    assert {-1, 1} <= set(data.direction[finite])
    assert data.t_coil_c.max() > 119 and data.t_target_c.max() > 129
    # coil heating happens in air; the coil-heated sweep has the target present
    hot_coil = data.t_coil_c > 110
    assert data.in_air[hot_coil].any() and finite[hot_coil].any()


def test_same_seed_same_campaign():
    a, b = paper_campaign(seed=5), paper_campaign(seed=5)
    np.testing.assert_array_equal(a.ls_h, b.ls_h)
    assert not np.array_equal(a.ls_h, paper_campaign(seed=6).ls_h)


def test_sweep_directions_and_backlash_reach_the_readings():
    config = LabConfig(effects=Effects(slide_backlash=SlideBacklash(enabled=True, backlash_um=200.0)), seed=0)
    config.noise.bridge_relative = {"slow": 0.0}
    data = displacement_sweep(SimulatedLab(config), positions_mm=(30.0, 50.0), frequencies_hz=(15000.0,))
    assert list(data.direction) == [1, 1, 1, -1]  # no move before the first backward reading
    forward, backward = data.ls_h[0], data.ls_h[3]  # both at 30 mm
    assert backward > forward  # approached from above, the carriage stops further away: less coupling


def test_coil_heating_is_in_air_and_switches_the_heater_off():
    lab = SimulatedLab(LabConfig(seed=0))
    data = coil_heating(lab, setpoints_c=(60.0,), frequencies_hz=(500.0,))
    assert data.in_air.all() and lab.config.target_present
    assert abs(data.t_coil_c.max() - 60.0) < 1.0
    assert not lab.supply[BOX_HEATER_OUTPUT].on
    assert data.t_coil_c[-1] < 25.0


def test_target_heating_reaches_steady_state_before_each_sweep():
    lab = SimulatedLab(LabConfig(seed=0))
    data = target_heating(lab, setpoints_c=(80.0,), positions_mm=(20.0, 100.0), frequencies_hz=(15000.0,))
    assert np.all(np.abs(data.t_target_c - 80.0) < 0.5)
    assert not lab.supply[TARGET_HEATER_OUTPUT].on
    assert np.all(np.isfinite(data.x_m)) and not math.isnan(data.ls_h.sum())
