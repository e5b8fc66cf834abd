"""The sensor under test: coil geometry, former, electrical constants and target.

Loaded from a small sensor YAML (a shipped name such as ``steel_target`` or a path); the
defaults are the paper's prototype (Gruber et al. 2024, Section 3: 500 turns of 0.3 mm wire,
winding 110-150 mm diameter, 3 mm high, ~57 mH at 15 kHz) facing a copper plate. A station
names its sensor and every run file records it, so analysis knows what was measured.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ecds_lab import shipped
from ecds_lab.errors import ConfigError

#: What analysis assumes when nothing says which sensor measured the data.
DEFAULT_SENSOR_NOTE = "sensor not recorded: analysed as the paper's copper prototype"

#: Thermal expansion of former materials, 1/K (docs/physics.md: gypsum 25e-6, fired clay 7.5e-6).
FORMER_EXPANSION_PER_K = {"gypsum": 25e-6, "fired_clay": 7.5e-6, "plastic": 70e-6}

#: Resistivity at 20 C (Ohm m) of the non-magnetic target materials (textbook, pure metals: copper 1.68e-8,
#: aluminium 2.65e-8; cartridge brass 6.4e-8); a target not listed is magnetic (steel), whose screening depth is
#: mu_r delta/2 (docs/physics.md, "A magnetic plate").
NON_MAGNETIC_RESISTIVITY_OHM_M = {"copper": 1.68e-8, "aluminium": 2.65e-8, "brass": 6.4e-8}
#: The target materials a sensor YAML may name (``target:``); "aluminum" is read as "aluminium".
TargetMaterial = Literal["copper", "aluminium", "brass", "steel"]
#: tau_T at 20 C, where the fit starts it (PHYSICS.md: copper's plate ~100 us, steel ~3 us). tau_T = L_T/R_T grows
#: with the conductivity, so the other non-magnetic plates start at copper's scaled by theirs (aluminium 63 us,
#: brass 26 us): a start, which the fit moves (its bounds span a factor 1000 either way).
COPPER_TAU_S = 100e-6
TARGET_TAU_S = {"steel": 3e-6, **{material: COPPER_TAU_S * NON_MAGNETIC_RESISTIVITY_OHM_M["copper"] / resistivity
                                  for material, resistivity in NON_MAGNETIC_RESISTIVITY_OHM_M.items()}}


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
    target: TargetMaterial = "copper"
    target_thickness_m: float | None = Field(None, gt=0, description="the target plate's thickness if known "
                                                                     "(else the conductivity effect fits it)")
    inductance_h: float = Field(57e-3, gt=0, description="air-coil L at the reference temperature")
    resistance_ohm: float = Field(50.0, gt=0, description="winding resistance at the reference temperature")
    resistance_tempco_per_k: float = 3900e-6
    capacitance_f: float = Field(47.5e-12, ge=0, description="parallel (inter-winding) capacitance, dry former")
    parallel_resistance_ohm: float = Field(984e3, gt=0, description="former loss as a parallel R, dry")
    reference_temperature_c: float = 20.0
    coupling_table: Path | None = Field(None, description="CSV of x_mm,k to use instead of the image method")

    @field_validator("target", mode="before")
    @classmethod
    def _british_spelling(cls, value: Any) -> Any:
        """``aluminum`` (US) names the same metal as ``aluminium``."""
        return "aluminium" if isinstance(value, str) and value.strip().lower() == "aluminum" else value

    @property
    def target_tau_s(self) -> float:
        return TARGET_TAU_S[self.target]

    @property
    def former_expansion_per_k(self) -> float:
        return FORMER_EXPANSION_PER_K[self.former]


def shipped_sensors() -> list[str]:
    """Names of the sensor YAMLs shipped with ecds-lab (``paper_prototype``, ``steel_target``...)."""
    return sorted(p.stem for p in shipped.sensors_folder().glob("*.yaml"))


def sensor_path(name: str | Path) -> Path:
    """The file a sensor reference names: a shipped name (no folder, no suffix) or a path; a name with a
    suffix but no folder (``steel_target.yaml``) that is no file here is a shipped name too, as for
    experiments and stations (config/references.py)."""
    text = str(name)
    if "/" in text or "\\" in text or Path(text).is_file():
        return Path(text)
    stem = text.removesuffix(".yaml") if text.endswith(".yaml") else text.removesuffix(".yml")
    if stem not in shipped_sensors():
        raise ConfigError(f"sensor {text!r}: no shipped sensor of that name; shipped: "
                          f"{', '.join(shipped_sensors())} (or give a path to a sensor YAML)")
    return shipped.sensors_folder() / f"{stem}.yaml"


def load_sensor(name: str | Path | None) -> SensorConfig:
    """Read a sensor YAML (shipped name or path), or return the paper's prototype when ``name`` is None.

    An unreadable file or a wrong field raises ConfigError naming the file, field and allowed values.
    """
    if name is None:
        return SensorConfig()
    path = sensor_path(name)
    try:
        doc = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the sensor file: {exc.strerror}") from exc
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {getattr(exc, 'problem', exc)}") from exc
    return sensor_from(str(path), doc)


def sensor_from(source: str, doc: object) -> SensorConfig:
    """Validate a parsed sensor description; errors name ``source``, the field, and what is allowed."""
    try:
        return SensorConfig.model_validate(doc if doc is not None else {})
    except ValidationError as exc:
        lines = []
        for item in exc.errors():
            field = ".".join(str(part) for part in item["loc"]) or "(top level)"
            message = item["msg"].removeprefix("Value error, ")
            if item["type"] == "extra_forbidden":
                message = "unknown key (check spelling)"
            given = item.get("input")
            shown = "" if item["type"] == "extra_forbidden" or isinstance(given, dict) else f" (given: {given!r})"
            lines.append(f"{source}: field '{field}': {message}{shown}")
        raise ConfigError("\n".join(lines)) from None
