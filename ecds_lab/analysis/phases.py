"""The phases of a campaign: stretches of one recording in which the set-up stayed as it was.

A new phase starts with a new recording, when the coil goes into or out of the air (target
removed or put back) and after a long pause without readings (a heater set point settling, the
set-up changed). Comparing readings within a phase keeps differences between phases (what was
done in between) from being credited to a variable that merely counts time.
"""

from __future__ import annotations

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.row_labels import row_labels

#: A pause longer than this (s) without readings starts a new phase.
MAX_PAUSE_S = 900.0


def phase_labels(data: Measurements, max_pause_s: float = MAX_PAUSE_S) -> np.ndarray:
    """Phase number of every row (0, 1, ... in time order within each recording)."""
    labels = np.zeros(len(data), int)
    next_label = 0
    for rows in data.segment_rows:
        if not len(rows):
            continue
        air = data.in_air[rows]
        pause = np.diff(data.time_s[rows], prepend=data.time_s[rows][0]) > max_pause_s
        change = np.concatenate([[False], air[1:] != air[:-1]]) | pause
        labels[rows] = next_label + np.cumsum(change)
        next_label = int(labels[rows].max()) + 1
    return labels


def within_phase(values: np.ndarray, labels: np.ndarray, also: np.ndarray | None = None) -> np.ndarray:
    """``values`` minus their mean in each phase (and in each class of ``also``, e.g. the frequency)."""
    key = labels if also is None else row_labels(labels, also)
    key = np.asarray(key).ravel()
    counts = np.bincount(key)
    means = np.bincount(key, weights=values) / np.maximum(counts, 1)
    return values - means[key]
