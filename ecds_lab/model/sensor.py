"""The sensor under test: coil geometry, former, electrical constants and target.

Loaded from a small sensor YAML; the defaults are the paper's prototype
(Gruber et al. 2024, Section 3: 500 turns of 0.3 mm wire, winding 110-150 mm
diameter, 3 mm high, ~57 mH at 15 kHz) facing a copper plate.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

#: Thermal expansion of former materials, 1/K (docs/physics.md: gypsum 25e-6, fired clay 7.5e-6).
FORMER_EXPANSION_PER_K = {"gypsum": 25e-6, "fired_clay": 7.5e-6, "plastic": 70e-6}

#: Target materials: eddy-current time constant tau_T at 20 C (docs/physics.md) and the
#: relative change of tau_T per kelvin (copper conductivity falls ~0.39 %/K).
TARGET_TAU_S = {"copper": 100e-6, "steel": 3e-6}
TARGET_TAU_TEMPCO_PER_K = {"copper": -0.0039, "steel": -0.0030}


class CoilGeometry(BaseModel):
    """Winding cross-section of the flat coil, SI units."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    inner_radius_m: float = Field(0.055, gt=0)
    outer_radius_m: float = Field(0.075, gt=0)
    height_m: float = Field(0.003, gt=0)
    turns: int = Field(500, gt=0)
    radial_filaments: int = Field(16, ge=1, le=200)
    axial_filaments: int = Field(3, ge=1, le=50)


class SensorConfig(BaseModel):
    """Everything the model needs to know about the sensor that is not fitted."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = "Gruber 2024 prototype"
    coil: CoilGeometry = CoilGeometry()
    former: Literal["gypsum", "fired_clay", "plastic"] = "fired_clay"
    target: Literal["copper", "steel"] = "copper"
    inductance_h: float = Field(57e-3, gt=0, description="air-coil L at the reference temperature")
    resistance_ohm: float = Field(50.0, gt=0, description="winding resistance at the reference temperature")
    resistance_tempco_per_k: float = 3900e-6
    capacitance_f: float = Field(47.5e-12, ge=0, description="parallel (inter-winding) capacitance, dry former")
    parallel_resistance_ohm: float = Field(984e3, gt=0, description="former loss as a parallel R, dry")
    reference_temperature_c: float = 20.0
    coupling_table: Path | None = Field(None, description="CSV of x_mm,k to use instead of the image method")

    @property
    def target_tau_s(self) -> float:
        return TARGET_TAU_S[self.target]

    @property
    def former_expansion_per_k(self) -> float:
        return FORMER_EXPANSION_PER_K[self.former]


def load_sensor(path: str | Path | None) -> SensorConfig:
    """Read a sensor YAML, or return the paper's prototype when ``path`` is None."""
    if path is None:
        return SensorConfig()
    from ecds_lab.config.loading import load_yaml_model

    return load_yaml_model(Path(path), SensorConfig)
