"""What a run file says about its run: experiment, station, status, times, identities, the sensor.

Run files keep these as string attributes of /entry; the sensor is recorded as the JSON of its
description (attribute ``sensor``), so analysis knows what was measured without the station file.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime

import yaml
from pydantic import ValidationError

from ecds_lab.data.sensor import SensorConfig
from ecds_lab.errors import RunFileError

#: The /entry attribute holding the sensor description (JSON of SensorConfig).
SENSOR_ATTRIBUTE = "sensor"
#: The /entry attribute holding the slide's declared positioning repeatability (1 sigma, metres) from the
#: station YAML (``slide.repeatability_um``); absent when the station declares none.
REPEATABILITY_ATTRIBUTE = "slide_repeatability_m"
#: /entry attribute: JSON list of one line per instrument link that discarded stale lines before its queries
#: (written at close; absent when there were none, and in older files).
LINK_NOTES_ATTRIBUTE = "link_notes"


def recorded_link_notes(attributes: Mapping[str, str]) -> list[str]:
    """The link notes a run file recorded (an unreadable attribute is itself a note, never an error)."""
    text = str(attributes.get(LINK_NOTES_ATTRIBUTE, "")).strip()
    if not text:
        return []
    try:
        notes = json.loads(text)
    except ValueError:
        return [f"/entry attribute {LINK_NOTES_ATTRIBUTE} is not JSON: {text[:80]!r}"]
    return [str(note) for note in notes] if isinstance(notes, list) else [str(notes)]


def sensor_attribute(sensor: SensorConfig) -> str:
    """The text a run file records for its sensor."""
    return sensor.model_dump_json()


def recorded_sensor(attributes: Mapping[str, str], source: str = "run file") -> SensorConfig | None:
    """The sensor a run file records, or None when its station named none (or it predates the field)."""
    text = attributes.get(SENSOR_ATTRIBUTE, "")
    if not text.strip():
        return None
    try:
        return SensorConfig.model_validate(json.loads(text))
    except (ValueError, ValidationError) as exc:
        raise RunFileError(f"{source}: the recorded sensor description is unreadable: {exc}") from None


def repeatability_attribute(repeatability_um: float | None) -> dict[str, str]:
    """The /entry attribute a run file records for its slide's declared repeatability (none when undeclared)."""
    return {} if repeatability_um is None else {REPEATABILITY_ATTRIBUTE: repr(repeatability_um / 1e6)}


def recorded_repeatability(attributes: Mapping[str, str], source: str = "run file") -> float:
    """The slide repeatability (1 sigma, m) a run file records; 0 when it records none (older files)."""
    text = str(attributes.get(REPEATABILITY_ATTRIBUTE, "")).strip()
    if not text:
        return 0.0
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise RunFileError(f"{source}: /entry attribute {REPEATABILITY_ATTRIBUTE} = {text!r} is not a repeatability "
                           "in metres (a number >= 0)")
    return value


@dataclass
class RunMetadata:
    """A run file's description of itself (strings as recorded; empty when absent)."""

    experiment: str = ""
    kind: str = ""
    station: str = ""
    status: str = ""
    start_time: str = ""
    end_time: str = ""
    points: int | None = None
    planned_points: int | None = None
    identities: dict[str, str] = field(default_factory=dict)
    faults: list[str] = field(default_factory=list)
    sensor: SensorConfig | None = None
    #: the slide's declared positioning repeatability, 1 sigma (m); 0 when the station declared none
    slide_repeatability_m: float = 0.0

    @property
    def wall_duration_s(self) -> float | None:
        """End minus start wall time, when both are recorded."""
        try:
            return (datetime.fromisoformat(self.end_time) - datetime.fromisoformat(self.start_time)).total_seconds()
        except ValueError:
            return None

    @classmethod
    def from_attributes(cls, attributes: Mapping[str, str], *, status: str, points: int, completed_points: int,
                        identities: Mapping[str, str], source: str = "run file") -> RunMetadata:
        """Build from /entry's attributes; faults list an error, an interruption and missing points."""
        faults = []
        if attributes.get("error"):
            faults.append(attributes["error"])
        if status == "interrupted":
            faults.append("the run was interrupted: its writer never closed the file (killed, crashed, or a write "
                          "failed on a full disk)")
        elif status not in ("completed", "unknown") and not attributes.get("error"):
            faults.append(f"the run ended as {status}")
        planned = _int_or_none(attributes.get("planned_points"))
        if planned is not None and completed_points < planned:
            faults.append(f"{completed_points} of {planned} planned points measured")
        station = _yaml_mapping(attributes.get("station_yaml", ""))
        return cls(experiment=attributes.get("experiment", ""), kind=attributes.get("kind", ""),
                   station=str(station.get("name", "")), status=status,
                   start_time=attributes.get("start_time", ""), end_time=attributes.get("end_time", ""),
                   points=points, planned_points=planned, identities=dict(identities), faults=faults,
                   sensor=recorded_sensor(attributes, source),
                   slide_repeatability_m=recorded_repeatability(attributes, source))


def _yaml_mapping(text: str) -> dict:
    try:
        doc = yaml.safe_load(text) if text else None
    except yaml.YAMLError:
        return {}
    return doc if isinstance(doc, dict) else {}


def _int_or_none(value: object) -> int | None:
    try:
        return int(str(value))
    except ValueError:
        return None
