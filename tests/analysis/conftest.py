"""Campaigns with hidden effects, made once per test session (they are pure functions of their config)."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig

#: 16 positions over 20-100 mm keep each campaign near 700 readings (fast, still every phase).
POSITIONS_MM = tuple(float(x) for x in np.linspace(20.0, 100.0, 16))


@cache
def hidden_effect_campaign(*effects: str, seed: int = 7):
    """The paper campaign with ``effects`` switched on at the simulated lab's realistic default sizes."""
    config = LabConfig(effects={name: {"enabled": True} for name in effects})
    return campaign.paper_campaign(config, seed=seed, positions_mm=POSITIONS_MM)


@pytest.fixture
def campaign_with():
    return hidden_effect_campaign
