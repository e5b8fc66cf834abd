"""A random subsample of a large campaign's readings, the same one every time (fixed seed, time order kept).

Where a step's answer shows on tens of thousands of readings as on all of them (screening candidates, ranking a
fit's starts, a scatter plot no eye can read point by point), it is taken on such a subsample: every position,
frequency and phase stays represented, which a fixed stride through sweeps of equal length would not guarantee.
"""

from __future__ import annotations

import numpy as np

from ecds_lab.data.measurements import Measurements


def random_rows(count: int, limit: int) -> np.ndarray:
    """Sorted indices of ``limit`` of ``count`` rows drawn at random (seed 0), or every row when there are no more."""
    if count <= limit:
        return np.arange(count)
    return np.sort(np.random.default_rng(0).choice(count, limit, replace=False))


def screened(data: Measurements, limit: int) -> Measurements:
    """The data themselves, or their random subsample of ``limit`` readings (``random_rows``)."""
    return data if len(data) <= limit else data.select(random_rows(len(data), limit))
