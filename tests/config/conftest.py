"""Bad inputs that once made ecds-lab hang, run out of memory or print a traceback (issue 13), as files.

Each case writes one broken file (small: the loader's work stays bounded) and says which file the
message must name and what else it must say (field, value, allowed values).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from ecds_lab.config.experiment import (
    MAX_DURATION_S,
    MAX_POSITIONS,
    MAX_READINGS,
    MIN_STEP_MM,
)
from ecds_lab.config.loading import MAX_VALUES

SILENT_CAPABLE = ("hm8118", "grbl", "daq970a", "34970a", "hmp4040")


@dataclass
class BadInput:
    """One broken file: the experiment and station to run, which of them is bad, what the message must say."""

    experiment: Path
    station: Path | None
    bad_file: Path
    expected: list[str]


Copy = Callable[..., Path]


def _station(experiments: Path) -> dict:
    return yaml.safe_load((experiments / "stations" / "simulated_lab.yaml").read_text())


def settle_infinite(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(settle_s=math.inf))
    assert ".inf" in path.read_text()
    return BadInput(path, None, path, ["field 'sweep.settle_s'", "not a finite number", "allowed: a finite number"])


def window_infinite(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = copy("coil_heating.yaml", lambda d: d["heating"]["steady"].update(window_s=math.inf))
    return BadInput(path, None, path, ["field 'heating.steady.window_s'", "not a finite number"])


def settle_huge(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(settle_s=1e300))
    return BadInput(path, None, path, ["field 'sweep.settle_s'", "less than or equal to 3600 s", "1e+300"])


def step_tiny(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = copy("target_heating_copper.yaml", lambda d: d["sweep"].update(step_mm=1e-7))
    return BadInput(path, None, path, ["field 'sweep.step_mm'", f"greater than or equal to {MIN_STEP_MM:g} mm"])


def too_many_positions(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = copy("target_heating_copper.yaml",
                lambda d: d["sweep"].update(start_mm=20.0, stop_mm=180.0, step_mm=0.001))
    return BadInput(path, None, path, ["field 'sweep'", "160001 positions", f"at most {MAX_POSITIONS} positions"])


def too_many_readings(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(repeats=1000, readings_per_point=100,
                                                                       settle_s=0.0))
    readings = 31 * 2 * 2 * 1000 * 100
    return BadInput(path, None, path, [f"the plan takes {readings} bridge readings", "sweep.repeats",
                                       f"allowed: at most {MAX_READINGS}"])


def longer_than_a_week(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(settle_s=3600.0, repeats=100))
    return BadInput(path, None, path, ["the plan takes at least", "days",
                                       f"allowed: at most {MAX_DURATION_S / 86400:.1f} days"])


def alias_bomb(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    """A "billion laughs" document: 9 levels of 9 aliases each, 9^9 values once expanded, 1 KiB on disk."""
    lines = ["kind: displacement_sweep", "sweep: {positions_mm: [20.0], frequencies_hz: [500]}",
             "lol0: &lol0 [20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 20.0]"]
    lines += [f"lol{i}: &lol{i} [{', '.join([f'*lol{i - 1}'] * 9)}]" for i in range(1, 9)]
    path = tmp_path / "bomb.yaml"
    path.write_text("\n".join(lines) + "\n")
    return BadInput(path, None, path, [f"more than {MAX_VALUES} values once YAML aliases are expanded"])


def duplicate_key(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = tmp_path / "duplicate.yaml"
    path.write_text("kind: displacement_sweep\nsweep:\n  positions_mm: [20.0, 30.0]\n  settle_s: 1.0\n"
                    "  frequencies_hz: [500]\n  settle_s: 20.0\n")
    return BadInput(path, None, path, ["field 'sweep.settle_s'", "(line 6)", "given twice (first on line 4)"])


def not_utf8(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = tmp_path / "latin1.yaml"
    text = "kind: displacement_sweep\ndescription: Messung bei 20 \u00b0C\n"
    path.write_bytes(text.encode("latin-1") + b"sweep: {positions_mm: [20.0], frequencies_hz: [500]}\n")
    offset = text.encode("latin-1").index(b"\xb0")
    return BadInput(path, None, path, ["not valid UTF-8", f"at byte {offset}", "line 2"])


def missing_station(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = tmp_path / "no_such_station.yaml"
    return BadInput(experiments / "displacement_sweep.yaml", path, path, ["cannot read", "No such file"])


def missing_experiment(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = tmp_path / "no_such_experiment.yaml"
    return BadInput(path, None, path, ["cannot read", "No such file"])


def min_mm_not_a_number(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    station = copy("stations/simulated_lab.yaml", lambda d: d["slide"]["options"].update(min_mm="abc"))
    return BadInput(experiments / "displacement_sweep.yaml", station, station,
                    ["field 'slide.options.min_mm'", "'abc'", "allowed: a finite number of mm"])


def min_mm_above_max_mm(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    high = _station(experiments)["slide"]["options"]["max_mm"]
    station = copy("stations/simulated_lab.yaml", lambda d: d["slide"]["options"].update(min_mm=high + 1))
    return BadInput(experiments / "displacement_sweep.yaml", station, station,
                    ["field 'slide.options.min_mm'", f"{high + 1:g} mm is not below max_mm {high:g} mm",
                     "allowed: min_mm < max_mm"])


def unknown_silent_instrument(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    def silence(d: dict) -> None:
        d["simulated"]["lab"].setdefault("faults", {})["silent_instruments"] = ["hm8118", "hm9999"]

    station = copy("stations/simulated_lab.yaml", silence)
    return BadInput(experiments / "displacement_sweep.yaml", station, station,
                    ["field 'simulated.lab.faults.silent_instruments.1'", "'hm9999'",
                     *(f"'{name}'" for name in SILENT_CAPABLE)])


def nan_in_station(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    station = copy("stations/simulated_lab.yaml", lambda d: d["safety"].update(heater_max_voltage_v=math.nan))
    return BadInput(experiments / "displacement_sweep.yaml", station, station,
                    ["field 'safety.heater_max_voltage_v'", "not a finite number"])


def nan_in_a_list(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(positions_mm=[20.0, math.nan, 30.0]))
    return BadInput(path, None, path, ["field 'sweep.positions_mm[1]'", "not a finite number"])


def min_mm_is_text(copy: Copy, tmp_path: Path, experiments: Path) -> BadInput:
    """``min_mm: "abc"`` in the experiment's sweep (a start position given as text)."""
    path = copy("target_heating_copper.yaml", lambda d: d["sweep"].update(start_mm="abc"))
    return BadInput(path, None, path, ["field 'sweep.start_mm'", "valid number", "'abc'"])


BAD_INPUTS: list[Callable[[Copy, Path, Path], BadInput]] = [
    settle_infinite, window_infinite, settle_huge, step_tiny, too_many_positions, too_many_readings,
    longer_than_a_week, alias_bomb, duplicate_key, not_utf8, missing_station, missing_experiment,
    min_mm_not_a_number, min_mm_above_max_mm, unknown_silent_instrument, nan_in_station, nan_in_a_list,
    min_mm_is_text,
]


@pytest.fixture(params=BAD_INPUTS, ids=[case.__name__ for case in BAD_INPUTS])
def bad_input(request: pytest.FixtureRequest, yaml_copy: Copy, tmp_path: Path, experiments_dir: Path) -> BadInput:
    return request.param(yaml_copy, tmp_path, experiments_dir)
