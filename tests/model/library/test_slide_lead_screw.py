"""slide_lead_screw: the periodic error of the screw shifts the effective distance; the effect is
testable only where the positions can resolve a lead."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import library, make_effect
from ecds_lab.model.library.slide_lead_screw import COMMON_LEADS_M, SlideLeadScrew, periodogram


@pytest.fixture
def screw() -> SlideLeadScrew:
    return SlideLeadScrew(SensorConfig())


def test_the_distance_runs_ahead_and_behind_over_one_lead(screw, readings_at):
    lead = 4e-3
    data = readings_at([40.0, 41.0, 42.0, 43.0, 44.0, math.inf])
    p = {"screw_sin": 10e-6, "screw_cos": -3e-6, "screw_lead": lead}
    moved = screw.effective_distance(data.x_m, data, p)
    shift = moved[:5] - data.x_m[:5]
    # 40 mm is ten turns: phase 0 (cos part only); 41 mm a quarter turn (sin part); 42 mm half a turn.
    np.testing.assert_allclose(shift * 1e6, [-3.0, 10.0, 3.0, -10.0, -3.0], atol=1e-6)
    assert np.isinf(moved[5])  # the coil in air stays in air


def test_the_hook_shifts_the_distance_it_is_given(screw, readings_at):
    """Chained after another distance effect, the error adds to that effect's distance."""
    data = readings_at(np.linspace(20.0, 30.0, 11))
    p = {"screw_sin": 5e-6, "screw_cos": 0.0, "screw_lead": 5e-3}
    moved = data.x_m - 1e-4
    np.testing.assert_allclose(screw.effective_distance(moved, data, p) - moved,
                               screw.effective_distance(data.x_m, data, p) - data.x_m, atol=1e-15)


def test_too_few_positions_or_steps_too_coarse_leave_it_undetermined(screw, readings_at):
    few = screw.unidentifiable(readings_at([20.0, 40.0, 60.0, 80.0, 100.0] * 4))
    assert set(few) == {"screw_sin", "screw_cos", "screw_lead"} and "5 distinct positions" in few["screw_lead"]
    coarse = screw.unidentifiable(readings_at(np.linspace(20.0, 100.0, 9)))  # 10 mm steps: no lead <= 20 mm
    assert set(coarse) == {"screw_sin", "screw_cos", "screw_lead"} and "10 mm apart" in coarse["screw_sin"]
    # 6.67 mm steps resolve the leads of 13.3-20 mm the effect declares (issue 23: its whole range is tested)
    assert screw.unidentifiable(readings_at(np.linspace(20.0, 100.0, 13))) == {}
    fine = np.r_[np.arange(20.0, 30.0, 1.0), np.arange(30.0, 100.1, 5.0)]
    assert screw.unidentifiable(readings_at([*fine, math.inf])) == {}


def test_it_is_in_the_library_with_plausible_sizes_and_the_common_leads_as_starts():
    assert library()["slide_lead_screw"] is SlideLeadScrew
    effect = make_effect("slide_lead_screw", SensorConfig())
    bounds = {p.name: (p.lower, p.upper) for p in effect.parameters()}
    for name, (low, high) in effect.plausible.items():
        assert bounds[name][0] < low < high < bounds[name][1]  # a fit beyond the plausible range can show it
    default = next(p.value for p in effect.parameters() if p.name == "screw_lead")
    assert default == max(COMMON_LEADS_M)  # the longest common lead first, the others as alternatives
    assert sorted([s["screw_lead"] for s in effect.alternative_starts] + [default]) == sorted(COMMON_LEADS_M)
    assert all(effect.plausible["screw_lead"][0] <= lead <= effect.plausible["screw_lead"][1]
               for lead in COMMON_LEADS_M)


def test_a_lead_the_positions_cannot_resolve_moves_nothing(screw, readings_at):
    """On 2 mm steps a 3 mm lead is an alias of a 6 mm one: the data cannot tell it, so it shifts nothing."""
    data = readings_at(np.arange(20.0, 60.0, 2.0))
    assert screw.shortest_lead(data) == pytest.approx(4e-3)
    p = {"screw_sin": 10e-6, "screw_cos": 0.0}
    np.testing.assert_array_equal(screw.effective_distance(data.x_m, data, {**p, "screw_lead": 3e-3}), data.x_m)
    assert np.ptp(screw.effective_distance(data.x_m, data, {**p, "screw_lead": 6e-3}) - data.x_m) > 15e-6


def test_one_close_pair_among_coarser_steps_resolves_no_shorter_lead(screw, readings_at):
    """Steps of 0.75 mm resolve leads from 1.5 mm; a pair 0.083 mm apart among them does not make a 0.78 mm lead
    (there an alias of a 22 mm wave) determinable: it moves nothing."""
    fine = np.r_[30.667, np.arange(30.75, 36.01, 0.75), np.arange(40.0, 100.1, 5.0)]
    data = readings_at(fine)
    assert screw.shortest_lead(data) == pytest.approx(1.5e-3)
    p = {"screw_sin": 10e-6, "screw_cos": 0.0}
    np.testing.assert_array_equal(screw.effective_distance(data.x_m, data, {**p, "screw_lead": 0.78e-3}), data.x_m)
    assert np.ptp(screw.effective_distance(data.x_m, data, {**p, "screw_lead": 1.6e-3}) - data.x_m) > 15e-6
    starts = screw.starts_from_residual(data, np.sin(2 * np.pi * data.x_m / 3e-3) * 1e-5, np.ones(len(data)))
    assert starts and min(start["screw_lead"] for start in starts) >= 1.5e-3  # the scan starts at the shortest


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_periodogram_is_the_generalised_lomb_scargle_one_before_its_normalisation(seed):
    """The scan's periodogram equals scipy's generalised Lomb-Scargle (weighted, floating mean, normalised) times the
    weighted sum of squares about the mean, on repeated, unevenly weighted positions with an offset in the data."""
    from scipy.signal import lombscargle

    rng = np.random.default_rng(seed)
    positions = np.round(np.sort(rng.uniform(20e-3, 100e-3, 60)), 6)
    x = np.repeat(positions, rng.integers(1, 5, len(positions)))
    y = 3e-6 * np.sin(2 * np.pi * x / 5e-3 + 0.3) + rng.normal(0.0, 2e-6, len(x)) + 1e-6
    w = rng.uniform(0.1, 2.0, len(x))
    omega = 2 * np.pi / np.geomspace(0.5e-3, 20e-3, 300)
    about_mean = np.sum(w * y**2) - np.sum(w * y) ** 2 / np.sum(w)
    expected = about_mean * lombscargle(x, y, omega, weights=w, floating_mean=True, normalize=True)
    np.testing.assert_allclose(periodogram(x, y, w, omega), expected, rtol=1e-9, atol=1e-12 * expected.max())
    assert omega[np.argmax(periodogram(x, y, w, omega))] == pytest.approx(2 * np.pi / 5e-3, rel=0.02)


def test_a_lead_at_which_every_position_has_one_phase_explains_nothing_beyond_the_mean():
    """Positions 2 mm apart all sit at one phase of a 2 mm (or 1 mm) lead: the sinusoid is the mean there, and the
    periodogram says so (nothing explained) instead of failing on its singular normal equations."""
    x = np.repeat(np.arange(20e-3, 40.1e-3, 2e-3), 2)
    y = np.random.default_rng(4).normal(0.0, 1e-6, len(x))
    power = periodogram(x, y, np.ones(len(x)), 2 * np.pi / np.array([2e-3, 1e-3, 7e-3]))
    assert power[:2] == pytest.approx([0.0, 0.0], abs=1e-9 * np.sum(y**2)) and power[2] > 0


def test_its_signature_is_the_amplitude_with_its_slopes(screw, readings_at):
    """A claim needs the error's amplitude known (checks.signature_spread): ln sqrt(a^2 + b^2) and its slopes."""
    data = readings_at([40.0, 41.0])
    p = {"screw_sin": 6e-6, "screw_cos": -8e-6, "screw_lead": 4e-3}
    ln_amplitude, slopes = screw.signature(data, p)
    assert ln_amplitude == pytest.approx(math.log(10e-6))
    step = 1e-9
    for name in ("screw_sin", "screw_cos"):
        moved = screw.signature(data, {**p, name: p[name] + step})[0]
        assert slopes[name] == pytest.approx((moved - ln_amplitude) / step, rel=1e-3)
    assert screw.signature(data, {**p, "screw_sin": 0.0, "screw_cos": 0.0}) is None
