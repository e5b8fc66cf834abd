"""What ships with ecds-lab, for ``ecds-lab list``: experiments (kind, one line), stations, sensors.

Each entry is read from its shipped file, so the list never disagrees with what ``run`` would load.
"""

from __future__ import annotations

from dataclasses import dataclass

from ecds_lab import shipped
from ecds_lab.config.experiment import EXPERIMENT_ADAPTER
from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.references import DEFAULT_STATION_NAME
from ecds_lab.config.station import StationConfig
from ecds_lab.data.sensor import load_sensor, shipped_sensors


@dataclass(frozen=True)
class Entry:
    """One shipped file: the name to give on the command line, a kind, and one line about it."""

    name: str
    kind: str
    line: str


def experiments() -> list[Entry]:
    """Every shipped experiment: its kind and its description's first line (else its name)."""
    entries = []
    for path in shipped.experiments():
        config = load_yaml_model(path, EXPERIMENT_ADAPTER)
        description = config.description.strip().splitlines()[0] if config.description.strip() else ""
        line = f"{config.name}: {description}" if description else config.name
        entries.append(Entry(path.stem, config.kind, line))
    return entries


def stations() -> list[Entry]:
    """Every shipped station: simulated or real, its name and the sensor it carries."""
    entries = []
    for path in sorted(shipped.stations_folder().glob("*.yaml")):
        config = load_yaml_model(path, StationConfig)
        sensor = f"; sensor: {config.sensor.name}" if config.sensor is not None else ""
        default = " (the default)" if path.stem == DEFAULT_STATION_NAME else ""
        entries.append(Entry(path.stem, "simulated" if config.simulated is not None else "real",
                             f"{config.name}{sensor}{default}"))
    return entries


def sensors() -> list[Entry]:
    """Every shipped sensor: its target metal and name."""
    entries = []
    for name in shipped_sensors():
        sensor = load_sensor(name)
        entries.append(Entry(name, f"{sensor.target} target", sensor.name))
    return entries


def format_catalogue() -> str:
    """The three lists as text, each headed by how its names are given on the command line."""
    sections = [("experiments (ecds-lab run NAME)", experiments()),
                ("stations (--station NAME)", stations()),
                ("sensors (--sensor NAME, or a station's 'sensor: NAME')", sensors())]
    lines = []
    for title, entries in sections:
        name_width = max(len(e.name) for e in entries)
        kind_width = max(len(e.kind) for e in entries)
        lines.append(f"{title}:")
        lines += [f"  {e.name:<{name_width}}  {e.kind:<{kind_width}}  {e.line}" for e in entries]
        lines.append("")
    return "\n".join(lines).rstrip("\n")
