"""The paper's Eq. (4) from steady coil temperatures in air: one glitch reading in a steady step must not move
the step's level (issue 24, point 1: a single 1.6 % reading in the 60 C step at 500 Hz moved alpha from +2.6 to
+19 ppm/K and left the compensated coil error at 0.63x the uncompensated one instead of 0.09x)."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.analysis.compensation import fit_steady_eq4, heated_coil_sweep, step_level
from ecds_lab.data.measurements import Measurements

ALPHA, BETA, L0, REFERENCE_C = 3e-6, 2.5e-8, 53.6e-3, 20.0
SETPOINTS_C = (22.0, 40.0, 60.0, 80.0, 100.0, 130.0)
NOISE = 20e-6
READINGS = 10


def _air_steps(glitch_step: int | None, glitch: float = 0.016, seed: int = 1) -> Measurements:
    """Coil in air held at each set point for ``READINGS`` readings at 500 Hz, L on Eq. (4) with bridge noise;
    one reading of step ``glitch_step`` off by ``glitch``."""
    rng = np.random.default_rng(seed)
    t = np.repeat(SETPOINTS_C, READINGS) + rng.normal(0, 0.05, READINGS * len(SETPOINTS_C))
    d = t - REFERENCE_C
    ls = L0 * (1 + ALPHA * d + BETA * d**2) * (1 + rng.normal(0, NOISE, len(t)))
    if glitch_step is not None:
        ls[glitch_step * READINGS + 3] *= 1 + glitch
    n = len(t)
    return Measurements(time_s=np.arange(n) * 60.0, x_m=np.full(n, np.inf), freq_hz=np.full(n, 500.0),
                        t_coil_c=t, t_target_c=np.full(n, 22.0), ls_h=ls, rs_ohm=np.full(n, 40.0))


def test_a_glitch_in_a_steady_step_leaves_alpha_where_the_clean_steps_put_it():
    clean = fit_steady_eq4(_air_steps(None), 500.0, REFERENCE_C)
    glitched = fit_steady_eq4(_air_steps(2), 500.0, REFERENCE_C)
    assert clean is not None and glitched is not None
    assert clean.alpha_per_k == pytest.approx(ALPHA, abs=1.5e-6)
    assert glitched.alpha_per_k == pytest.approx(clean.alpha_per_k, abs=0.3e-6)
    assert glitched.glitches_excluded == 1 and clean.glitches_excluded == 0


def test_a_glitch_does_not_scale_the_heated_coil_sweep_built_from_its_step():
    n = 9
    room = Measurements(time_s=np.arange(n) * 10.0, x_m=np.linspace(20e-3, 100e-3, n), freq_hz=np.full(n, 500.0),
                        t_coil_c=np.full(n, 22.0), t_target_c=np.full(n, 22.0), ls_h=np.linspace(40e-3, 52e-3, n),
                        rs_ohm=np.full(n, 40.0))
    built = heated_coil_sweep(room, _air_steps(2))
    at_60 = built.select(np.abs(built.t_coil_c - 60.0) < 2.0)
    ratio = at_60.ls_h / room.ls_h
    expected = (1 + ALPHA * 40 + BETA * 40**2) / (1 + ALPHA * 2 + BETA * 4)
    assert np.max(np.abs(ratio / expected - 1)) < 30e-6  # the glitch alone would put it 1600 ppm off


def test_step_level_is_the_mean_without_the_glitch():
    values = np.array([1.0, 1.00002, 0.99998, 1.016, 1.00001, 0.99999])
    level, excluded = step_level(values)
    assert excluded.tolist() == [3]
    assert level == pytest.approx(np.mean(np.delete(values, 3)), rel=1e-12)
    assert step_level(np.array([2.0]))[0] == 2.0
    level, excluded = step_level(np.array([1.0, 1.0, 1.0]))
    assert level == 1.0 and not len(excluded)


def test_a_step_still_settling_keeps_its_first_readings():
    """The demo's 15 kHz step at 40 C starts 285, 213 and 91 ppm above its later readings (the coil settling):
    readings that deviate together are the coil's, not glitches, and stay in the step's mean."""
    settle = np.array([285.0, 213.0, 91.0, 5.0, -15.0, -4.0, -44.0, 16.0, -18.0, 0.0, -109.0])
    values = 55e-3 * (1 + settle * 1e-6)
    level, excluded = step_level(values)
    assert not len(excluded)
    assert level == pytest.approx(np.mean(values), rel=1e-12)
    glitched = values.copy()
    glitched[6] *= 1.016
    assert step_level(glitched)[1].tolist() == [6]
