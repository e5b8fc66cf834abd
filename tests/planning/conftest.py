"""Starting campaigns on the faithful simulated lab with a chosen truth, measured through ``ecds-lab run``.

The truth is switched on by its documented name and size in the station's ``simulated: lab:`` block
(docs/simulated_lab.md), over the study's quiet lab (``ecds_lab.study.campaigns.QUIET_LAB``: every documented
imperfection off), so the truth is exactly what was switched on plus the field solution's own physics.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

from ecds_lab import shipped
from ecds_lab.runner.session import run_experiment
from ecds_lab.study.campaigns import QUIET_LAB
from ecds_lab.study.cases import merged

STEADY = {"slope_k_per_min": 0.1, "window_s": 300, "tolerance_k": 1.0, "interval_s": 10, "timeout_s": 21600}


def _truth_station(folder: Path, truth: dict[str, Any], *, slide: dict[str, Any] | None = None,
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


def _target_start(frequencies: list[float], direction: str = "both") -> dict[str, Any]:
    """A short one-temperature target heating: a sweep at room temperature and at 75 C, 9 positions."""
    return {"kind": "target_heating", "name": "start", "heating": {"setpoints_c": [24.0, 75.0], "steady": STEADY,
                                                                  "log_interval_s": 120},
            "sweep": {"positions_mm": [20, 30, 40, 50, 60, 70, 80, 90, 100], "frequencies_hz": frequencies,
                      "direction": direction, "readings_per_point": 2, "settle_s": 2.0}}


def _measured(folder: Path, station: Path, experiment: dict[str, Any], name: str = "start") -> Path:
    """Run ``experiment`` on ``station``; the run file."""
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(experiment, sort_keys=False), encoding="utf-8")
    result = run_experiment(path, station, folder / f"{name}.h5", progress=False)
    assert result.status == "completed", result.error
    return folder / f"{name}.h5"


STEADY_START = {"slope_k_per_min": 0.1, "window_s": 300, "tolerance_k": 1.0, "interval_s": 10, "timeout_s": 21600}
BENDING = {"plate": {"bending": {"enabled": True, "centre_rise_um_per_k": 1.0}}}


def starting_cases() -> dict[str, tuple[dict[str, Any], dict[str, Any], dict[str, Any]]]:
    """The issue's starting campaigns: case -> (truth, slide options, starting experiment)."""
    coil = {"kind": "coil_heating", "name": "start", "park_mm": 160.0, "frequencies_hz": [500, 15000], "readings": 3,
            "heating": {"setpoints_c": [60.0], "steady": STEADY_START, "log_interval_s": 120, "cool_down_to_c": 30.0}}
    # every 4 mm: a 15.5 mm wide bump (docs/simulated_lab.md) between positions 10 mm apart is taken for tau_T(x)
    sweep = {"kind": "displacement_sweep", "name": "start",
             "sweep": {"start_mm": 20.0, "stop_mm": 100.0, "step_mm": 4.0, "frequencies_hz": [500, 15000],
                       "direction": "both", "readings_per_point": 2}}
    return {
        # (a) one frequency, target heated, truth a bending
        "a": (BENDING, {}, _target_start([15000.0])),
        # (b) the same, truth a conductivity change
        "b": ({"plate": {"conductivity": {"enabled": True}}}, {}, _target_start([15000.0])),
        # (c) sweeps in one direction only (a slide that approaches directly), a backlash beside a bending
        "c": ({**BENDING, "slide": {"backlash": {"enabled": True, "backlash_um": 40.0}}}, {"approach": "direct"},
              _target_start([500.0, 15000.0], "forward")),
        # (d) a short coil heating, truth the former's moisture drying (the winding's lag is always there)
        "d": ({"former": {"moisture": {"enabled": True, "initial": 1.0}}}, {}, coil),
        # (e) a truth outside the library: a metal object beside the slide
        "e": ({"imperfections": {"metal_object": {"enabled": True, "position_mm": 45.0, "radius_mm": 3.0}}}, {},
              sweep),
    }


@pytest.fixture(name="starting_cases")
def starting_cases_fixture() -> dict[str, tuple[dict[str, Any], dict[str, Any], dict[str, Any]]]:
    return starting_cases()


@pytest.fixture
def truth_station() -> Callable[..., Path]:
    return _truth_station


@pytest.fixture
def measured() -> Callable[..., Path]:
    return _measured


@pytest.fixture
def target_start() -> Callable[..., dict[str, Any]]:
    return _target_start


@pytest.fixture
def tight_limits(tmp_path: Path) -> tuple[Path, Path]:
    """Case (a) on a station with tight limits (travel to 90 mm, target below 60 C, coil below 50 C), measured
    inside them: (the station file, the run file)."""
    truth, _, experiment = starting_cases()["a"]
    station = _truth_station(tmp_path, truth, slide={"max_mm": 90.0},
                             safety={"max_temperature_c": {"target": 60.0, "coil": 50.0}})
    experiment = {**experiment, "heating": {**experiment["heating"], "setpoints_c": [24.0, 45.0]},
                  "sweep": {**experiment["sweep"], "positions_mm": [20, 30, 40, 50, 60, 70, 80, 90]}}
    return station, _measured(tmp_path, station, experiment)


@pytest.fixture(scope="session")
def _started_cache(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, Path]]:
    return {}


@pytest.fixture
def started(_started_cache: dict[str, tuple[Path, Path]], tmp_path_factory: pytest.TempPathFactory
            ) -> Callable[[str], tuple[Path, Path]]:
    """``started(case)``: the case's station YAML and its starting run file, measured once per test session (the
    files are only read; every test writes its own runs in its own folder)."""

    def make(case: str) -> tuple[Path, Path]:
        if case not in _started_cache:
            folder = tmp_path_factory.mktemp(f"start_{case}")
            truth, slide, experiment = starting_cases()[case]
            station = _truth_station(folder, truth, slide=slide)
            _started_cache[case] = (station, _measured(folder, station, experiment))
        return _started_cache[case]

    return make
