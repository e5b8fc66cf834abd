"""Campaigns with hidden effects, made once per test session (they are pure functions of their config)."""

from __future__ import annotations

import dataclasses
import json
from functools import cache

import numpy as np
import pytest

from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.study.campaigns import QUIET_LAB, measure
from ecds_lab.study.cases import draw_case, merged

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


@cache
def _study_campaign(seed: int, number: int):
    """Campaign ``number`` of the validation study drawn with ``seed`` (benchmarks/validation_study.py)."""
    return measure(draw_case(number, seed))


@pytest.fixture
def study_campaign():
    return _study_campaign


def field_lab_config(seed: int = 3, **parts: dict) -> LabConfig:
    """The faithful lab (physics: field) with only ``parts`` switched on, e.g. plate={"bending": {...}}."""
    return LabConfig(physics="field", seed=seed, **merged(QUIET_LAB, parts))


@pytest.fixture
def field_lab():
    """Factory: a fresh faithful simulated lab with only the given parts of its physics switched on."""
    return lambda seed=3, **parts: SimulatedLab(field_lab_config(seed, **parts))


@pytest.fixture
def field_config():
    """Factory: the faithful lab's config (``field_lab_config``), for campaigns built from a config."""
    return field_lab_config


def spread_rows(data, count: int, seed: int) -> list[int]:
    """Rows away from the ends of every sweep (where a glitch cannot be told from a turning point)."""
    rng = np.random.default_rng(seed)
    finite = np.flatnonzero(np.isfinite(data.x_m) & (data.x_mm > 30) & (data.x_mm < 90))
    return sorted(rng.choice(finite, count, replace=False).tolist())


@pytest.fixture
def glitched():
    """Factory: (data with ``count`` readings the bridge got wrong by ``ppm``, the rows hit)."""
    def make(data, count: int, ppm: float, seed: int):
        rows = spread_rows(data, count, seed)
        ls = data.ls_h.copy()
        ls[rows] *= 1 + ppm * 1e-6
        return dataclasses.replace(data, ls_h=ls), rows
    return make


@cache
def _field_paper_campaign(parts_json: str, frequencies_hz: tuple[float, ...]):
    config = field_lab_config(**json.loads(parts_json))
    return campaign.paper_campaign(config, seed=config.seed, positions_mm=POSITIONS_MM, frequencies_hz=frequencies_hz)


@pytest.fixture
def field_campaign():
    """Factory: the paper's campaign on the faithful lab with only ``parts`` on (made once per session)."""
    def make(frequencies_hz: tuple[float, ...] = campaign.PAPER_FREQUENCIES_HZ, **parts: dict):
        return _field_paper_campaign(json.dumps(parts, sort_keys=True), tuple(frequencies_hz))
    return make


#: Steps finer than a screw's lead near the coil, as the demo's sweep (1 mm, then 2, 2.5 and 5 mm).
FINE_POSITIONS_MM = tuple(np.r_[np.arange(20.0, 30.0, 1.0), np.arange(30.0, 40.0, 2.0), np.arange(40.0, 50.0, 2.5),
                                np.arange(50.0, 100.1, 5.0)].tolist())


@cache
def faithful_sweep(seed: int = 1, *, screw_um: float = 0.0, lead_mm: float = 4.0, repeatability_um: float = 0.0):
    """A room-temperature sweep (both directions, both frequencies, two readings each) on the faithful
    lab (``physics: field``) without backlash, with a lead screw's periodic error of ``screw_um`` over
    ``lead_mm`` and a random scatter of ``repeatability_um`` (1 sigma) per move; 0 switches one off."""
    slide = {"backlash": {"enabled": False},
             "lead_screw": {"enabled": screw_um > 0, "amplitude_um": screw_um, "pitch_mm": lead_mm},
             "repeatability": {"enabled": repeatability_um > 0, "sigma_um": repeatability_um}}
    lab = SimulatedLab(LabConfig(physics="field", seed=seed, slide=slide))
    return campaign.displacement_sweep(lab, FINE_POSITIONS_MM, repeats=2)


@pytest.fixture
def faithful_sweep_with():
    return faithful_sweep


def with_metal_object(data, ppm: float = -400.0, at_mm: float = 47.0, width_mm: float = 5.0):
    """The README's example (docs/user_effects.md): a metal object beside the slide changes L by ``ppm``
    in a Gaussian of ``width_mm`` around ``at_mm``."""
    x_mm = np.where(np.isfinite(data.x_m), data.x_mm, np.inf)
    bump = 1 + ppm * 1e-6 * np.exp(-0.5 * ((x_mm - at_mm) / width_mm) ** 2)
    return dataclasses.replace(data, ls_h=data.ls_h * bump)


@pytest.fixture
def metal_object():
    return with_metal_object


@pytest.fixture
def fine_positions_mm():
    return FINE_POSITIONS_MM
