"""The slide's carriage: where it really is for a motor position and direction of approach.

The paper's slide is a stepper-driven lead screw checked with a laser sensor to "low tens of um".
The carriage trails the nut by half the backlash against the direction of the last move, the lead
screw adds a periodic error over each revolution (pitch), and each move ends within a repeatability
(normal, drawn once per move).
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from ecds_lab.simulators.physics._settings import Strict


class Backlash(Strict):
    enabled: bool = True
    backlash_um: float = Field(20.0, ge=0, description="lost motion on reversal")


class LeadScrew(Strict):
    enabled: bool = True
    amplitude_um: float = Field(8.0, ge=0, description="periodic error amplitude")
    pitch_mm: float = Field(5.0, gt=0, description="one screw revolution")
    phase_rad: float = 0.0


class Repeatability(Strict):
    enabled: bool = True
    sigma_um: float = Field(5.0, ge=0, description="scatter of the end position of a move (1 sigma)")


class SlideMechanicsSettings(Strict):
    """Carriage errors of the slide (paper Sec. 2.2.1: accuracy in the low tens of um)."""

    backlash: Backlash = Backlash()
    lead_screw: LeadScrew = LeadScrew()
    repeatability: Repeatability = Repeatability()


def carriage_error_m(settings: SlideMechanicsSettings, motor_mm: float, direction: int, scatter_m: float) -> float:
    """True carriage position minus motor position (m) for a carriage approached in ``direction``."""
    error = scatter_m if settings.repeatability.enabled else 0.0
    if settings.backlash.enabled:
        error -= direction * settings.backlash.backlash_um * 0.5e-6
    screw = settings.lead_screw
    if screw.enabled:
        error += screw.amplitude_um * 1e-6 * math.sin(2 * math.pi * motor_mm / screw.pitch_mm + screw.phase_rad)
    return error


def draw_scatter_m(settings: SlideMechanicsSettings, rng: np.random.Generator) -> float:
    """The repeatability scatter of one move (m)."""
    r = settings.repeatability
    return float(rng.normal(0.0, r.sigma_um * 1e-6)) if r.enabled and r.sigma_um > 0 else 0.0
