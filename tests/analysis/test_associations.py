"""Residual associations: the variable a residual depends on comes first; noise scores near zero."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.analysis.associations import BEYOND_CHANCE, residual_associations
from ecds_lab.analysis.grouping import visit_labels
from ecds_lab.data.measurements import Measurements
from ecds_lab.study.campaigns import measure
from ecds_lab.study.cases import Case, Design


@pytest.fixture
def data() -> Measurements:
    rng = np.random.default_rng(5)
    n = 1200
    t = np.sort(rng.uniform(0, 36000, n))
    return Measurements(time_s=t, x_m=rng.choice(np.linspace(0.02, 0.1, 17), n),
                        freq_hz=rng.choice([500.0, 15000.0], n), t_coil_c=rng.uniform(22, 130, n),
                        t_target_c=rng.uniform(22, 130, n), ls_h=np.full(n, 0.05), rs_ohm=np.full(n, 100.0))


@pytest.mark.parametrize("variable, shape", [
    ("t_coil_c", lambda d: 3.0 * (d.t_coil_c - 22)),
    ("t_target_c", lambda d: np.where(d.freq_hz == 500, 5.0, 1.0) * (d.t_target_c - 22)),
    ("x_mm", lambda d: 4000.0 / d.x_mm),
    ("time_s", lambda d: d.time_s / 100.0),
])
def test_the_variable_the_residual_lives_in_comes_first(data, variable, shape):
    noise = np.random.default_rng(1).normal(0, 20, len(data))
    found = residual_associations(data, shape(data) + noise, noise_ppm=20.0)
    assert found[0].variable == variable
    assert found[0].score > 0.5


def test_pure_noise_scores_near_zero(data):
    noise = np.random.default_rng(2).normal(0, 20, len(data))
    assert max(a.score for a in residual_associations(data, noise, noise_ppm=20.0)) < 0.05


def test_detail_names_the_frequency_where_the_residual_is_larger(data):
    residual = np.where(data.freq_hz == 500, 5.0, 1.0) * (data.t_target_c - 22)
    target = next(a for a in residual_associations(data, residual, 1.0) if a.variable == "t_target_c")
    assert "larger at 500 Hz" in target.detail


@pytest.fixture(scope="module")
def cold_then_hot() -> Measurements:
    """The readings' inputs of a short campaign on the quiet faithful lab (the validation study's design of case 25):
    readings in air, a cold sweep at two frequencies, the target heated to 75 C for an hour, a hot sweep, the target
    cooling back to room temperature with the coil in air; the coil's temperature wanders 0.1 K with the room."""
    design = Design((500.0, 15000.0), ("forward",), 9, False, (75.0,), (), 1)
    return measure(Case(0, 1, design, (), {}))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_drift_between_phases_ranks_time_before_the_target_temperature_it_moves_with(cold_then_hot, seed):
    """A gain drift of 150 ppm/h is small within each short phase, but the target temperature explains nothing of it
    once time is taken out (readings in air before and after) while time explains it beyond the temperature: time
    leads (validation study case 25 named the target temperature and the coil's 0.1 K wander instead)."""
    data = cold_then_hot
    residual = 150.0 * data.time_s / 3600.0 + np.random.default_rng(seed).normal(0, 20, len(data))
    found = residual_associations(data, residual - residual.mean(), noise_ppm=20.0)
    assert found[0].variable == "time_s", [(a.variable, a.significance) for a in found]
    assert "along the campaign it explains what" in found[0].detail


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_an_effect_of_the_hot_target_keeps_the_target_temperature_first(cold_then_hot, seed):
    data = cold_then_hot
    hot = np.isfinite(data.x_m) & (data.t_target_c > 50)
    residual = np.where(hot, 150.0, 0.0) + np.random.default_rng(seed).normal(0, 20, len(data))
    found = residual_associations(data, residual - residual.mean(), noise_ppm=20.0)
    assert found[0].variable == "t_target_c", [(a.variable, a.significance) for a in found]


@pytest.fixture(scope="module")
def both_ways() -> Measurements:
    """As ``cold_then_hot``, every sweep approaching from both directions."""
    design = Design((500.0, 15000.0), ("forward", "backward"), 9, False, (75.0,), (), 1)
    return measure(Case(0, 1, design, (), {}))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_direction_seen_at_one_visit_is_that_visit_not_the_direction(cold_then_hot, seed):
    """Forward sweeps: the only readings approached downward are the first of the hot sweep, one stop of the slide
    (small coil, validation study seed 2037 case 121: -75 and -60 ppm there, said to live in the direction at 12 sd).
    Their offset is that visit's (its carriage error, the moment's state), no evidence about the direction (6.5 to
    19.9 sd before)."""
    data = cold_then_hot
    down = np.isfinite(data.x_m) & (data.direction < 0)
    assert len(np.unique(visit_labels(data)[down])) == 1
    residual = np.where(down, -75.0, 0.0) + np.random.default_rng(seed).normal(0, 20, len(data))
    direction = next(a for a in residual_associations(data, residual - residual.mean(), 20.0)
                     if a.variable == "direction")
    assert direction.significance < BEYOND_CHANCE and "downward" not in direction.detail


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_direction_seen_at_every_stop_of_a_sweep_leads(both_ways, seed):
    data = both_ways
    down = np.isfinite(data.x_m) & (data.direction < 0)
    assert len(np.unique(visit_labels(data)[down])) >= 9
    residual = np.where(down, -75.0, 0.0) + np.random.default_rng(seed).normal(0, 20, len(data))
    found = residual_associations(data, residual - residual.mean(), 20.0)
    assert found[0].variable == "direction" and found[0].significance > BEYOND_CHANCE
