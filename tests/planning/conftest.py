"""Starting campaigns on the faithful simulated lab with a chosen truth, measured through ``ecds-lab run``.

The truth is switched on by its documented name and size in the station's ``simulated: lab:`` block
(docs/simulated_lab.md), over the study's quiet lab (``ecds_lab.study.campaigns.QUIET_LAB``: every documented
imperfection off), so the truth is exactly what was switched on plus the field solution's own physics.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from ecds_lab import shipped
from ecds_lab.runner.session import run_experiment
from ecds_lab.study.campaigns import QUIET_LAB
from ecds_lab.study.cases import merged

STEADY = {"slope_k_per_min": 0.1, "window_s": 300, "tolerance_k": 1.0, "interval_s": 10, "timeout_s": 21600}


def truth_station(folder: Path, truth: dict[str, Any], *, slide: dict[str, Any] | None = None,
                  safety: dict[str, Any] | None = None, name: str = "station.yaml") -> Path:
    """The shipped simulated station, quiet but for ``truth``, its slide options and safety limits changed."""
    station = yaml.safe_load(shipped.station().read_text(encoding="utf-8"))
    station["simulated"]["lab"] = merged(merged(station["simulated"]["lab"], QUIET_LAB), truth)
    station["simulated"]["lab"]["seed"] = 1234
    station["slide"]["repeatability_um"] = 0.0  # the quiet lab's slide has no random scatter
    station["slide"]["options"].update(slide or {})
    station["safety"] = merged(station["safety"], safety or {})
    path = folder / name
    path.write_text(yaml.safe_dump(station, sort_keys=False), encoding="utf-8")
    return path


def target_start(frequencies: list[float], direction: str = "both") -> dict[str, Any]:
    """A short one-temperature target heating: a sweep at room temperature and at 75 C, 9 positions."""
    return {"kind": "target_heating", "name": "start", "heating": {"setpoints_c": [24.0, 75.0], "steady": STEADY,
                                                                  "log_interval_s": 120},
            "sweep": {"positions_mm": [20, 30, 40, 50, 60, 70, 80, 90, 100], "frequencies_hz": frequencies,
                      "direction": direction, "readings_per_point": 2, "settle_s": 2.0}}


def measured(folder: Path, station: Path, experiment: dict[str, Any], name: str = "start") -> Path:
    """Run ``experiment`` on ``station``; the run file."""
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(experiment, sort_keys=False), encoding="utf-8")
    result = run_experiment(path, station, folder / f"{name}.h5", progress=False)
    assert result.status == "completed", result.error
    return folder / f"{name}.h5"
