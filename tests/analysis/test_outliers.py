"""Glitch detection: isolated readings are flagged, runs of structure never are."""

from __future__ import annotations

import dataclasses

import numpy as np

from ecds_lab.analysis.outliers import find_glitches
from ecds_lab.data.measurements import Measurements
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

NOISE_PPM = 20.0


def sweeps() -> Measurements:
    """Three upward sweeps at 500 Hz and 15 kHz (readings of both frequencies taken together), one
    series of like readings from the first to the last, as in the demo's target heating."""
    lab = SimulatedLab(LabConfig(seed=5))
    positions = tuple(float(x) for x in range(20, 101, 10))
    runs = [campaign.displacement_sweep(lab, positions, directions=("forward",)) for _ in range(3)]
    data = Measurements.concatenate(runs)
    assert np.all(np.diff(data.time_s) > 0)
    return dataclasses.replace(data, segment=np.zeros_like(data.segment))  # one recording


def transient(data: Measurements, sweep_start: float, sweep_end: float) -> np.ndarray:
    """A sweep made before a thermal state settled: +3400 ppm at 20 mm at 500 Hz decaying smoothly with
    x (to a few sigma by 60 mm), the opposite sign and a little smaller at 15 kHz; only in one sweep."""
    inside = (data.time_s >= sweep_start) & (data.time_s <= sweep_end)
    shape = np.exp(-(data.x_mm - 20.0) / 10.0) * 3400.0
    return np.where(inside, np.where(data.freq_hz < 1000, shape, -0.8 * shape), 0.0)


def second_sweep(data: Measurements) -> tuple[float, float]:
    """Start and end time of the second sweep (the middle of the series, where every reading is judged)."""
    starts = np.flatnonzero(np.diff(data.x_mm) < 0) + 1
    return float(data.time_s[starts[0]]), float(data.time_s[starts[1] - 1])


def test_a_smooth_transient_in_one_sweep_keeps_every_reading():
    data = sweeps()
    residual = np.random.default_rng(1).normal(0, NOISE_PPM, len(data))
    residual += transient(data, *second_sweep(data))
    assert np.abs(residual).max() > 100 * NOISE_PPM  # far beyond the glitch threshold
    assert not find_glitches(data, residual, NOISE_PPM).any()


def test_two_isolated_glitches_are_flagged_exactly():
    data = sweeps()
    residual = np.random.default_rng(2).normal(0, NOISE_PPM, len(data))
    residual += transient(data, *second_sweep(data))
    inner = np.flatnonzero((data.x_mm > 30) & (data.x_mm < 90) & (data.time_s > second_sweep(data)[1] + 1))
    rows = sorted(np.random.default_rng(3).choice(inner, 2, replace=False).tolist())
    residual[rows] += [2500.0, -3000.0]
    assert np.flatnonzero(find_glitches(data, residual, NOISE_PPM)).tolist() == rows
