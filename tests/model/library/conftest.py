"""Readings at chosen positions for the library's effects: the slide's position, its direction of approach and the
temperatures are what these effects read; the bridge's values are placeholders."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.data.measurements import Measurements


def _readings_at(x_mm, direction=None, t_coil_c=22.0, t_target_c=22.0) -> Measurements:
    """Readings at ``x_mm`` (inf: coil in air), at 15 kHz; ``direction`` of approach (default: worked out from the
    order of the positions), coil and target temperatures (one value or one per reading)."""
    x = np.asarray(x_mm, float)
    n = len(x)
    per_reading = {"direction": np.broadcast_to(np.asarray(direction, int), (n,)).copy()} if direction is not None \
        else {}
    return Measurements(time_s=np.arange(n, dtype=float), x_m=x * 1e-3, freq_hz=np.full(n, 15000.0),
                        t_coil_c=np.broadcast_to(np.asarray(t_coil_c, float), (n,)).copy(),
                        t_target_c=np.broadcast_to(np.asarray(t_target_c, float), (n,)).copy(),
                        ls_h=np.full(n, 0.05), rs_ohm=np.full(n, 20.0), **per_reading)


@pytest.fixture
def readings_at():
    return _readings_at
