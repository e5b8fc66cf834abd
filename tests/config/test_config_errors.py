"""Bad station and experiment files stop a run before any instrument is touched, with a message that names
the file, the field and the allowed values; the command line exits with code 2 and says so on stderr."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import get_args

import pytest
import yaml

from ecds_lab.cli import main
from ecds_lab.config.experiment import SweepConfig
from ecds_lab.drivers.hm8118 import FREQUENCIES_HZ
from ecds_lab.errors import ConfigError
from ecds_lab.instruments.kinds import KINDS, drivers_for_role
from ecds_lab.runner.session import prepare, run_experiment
from ecds_lab.simulators.physics.plate import Bending


@dataclass
class BadConfig:
    """One broken file: the experiment and station to run, which of them is bad, what the message must say."""

    experiment: Path
    station: Path | None
    bad_file: Path
    expected: list[str]


def station_yaml(experiments_dir: Path) -> dict:
    return yaml.safe_load((experiments_dir / "stations" / "simulated_lab.yaml").read_text())


def unknown_key(copy, tmp_path, experiments) -> BadConfig:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(settle_sec=2.0))
    return BadConfig(path, None, path, ["field 'sweep.settle_sec'", "unknown key", *SweepConfig.model_fields])


def unknown_key_in_station(copy, tmp_path, experiments) -> BadConfig:
    station = copy("stations/simulated_lab.yaml",
                   lambda d: d["simulated"]["lab"]["plate"]["bending"].update(shift_um=2.0))
    return BadConfig(experiments / "displacement_sweep.yaml", station, station,
                     ["field 'simulated.lab.plate.bending.shift_um'", "unknown key",
                      "allowed: " + ", ".join(sorted(Bending.model_fields))])


def wrong_type(copy, tmp_path, experiments) -> BadConfig:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(repeats="twice"))
    return BadConfig(path, None, path, ["field 'sweep.repeats'", "valid integer", "'twice'"])


def wrong_choice(copy, tmp_path, experiments) -> BadConfig:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(direction="sideways"))
    choices = get_args(SweepConfig.model_fields["direction"].annotation)
    return BadConfig(path, None, path, ["field 'sweep.direction'", "'sideways'", *(f"'{c}'" for c in choices)])


def wrong_type_in_station(copy, tmp_path, experiments) -> BadConfig:
    station = copy("stations/simulated_lab.yaml", lambda d: d["safety"].update(heater_max_voltage_v="thirty"))
    return BadConfig(experiments / "displacement_sweep.yaml", station, station,
                     ["field 'safety.heater_max_voltage_v'", "valid number", "'thirty'"])


def frequency_not_on_the_bridge(copy, tmp_path, experiments) -> BadConfig:
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(frequencies_hz=[500, 12345]))
    return BadConfig(path, None, path, ["field 'sweep.frequencies_hz'", "12345 Hz", "HM8118",
                                        "allowed: " + ", ".join(str(f) for f in FREQUENCIES_HZ)])


def _travel(experiments: Path) -> str:
    options = station_yaml(experiments)["slide"]["options"]
    return f"allowed {options['min_mm']:g}..{options['max_mm']:g} mm"


def position_beyond_travel(copy, tmp_path, experiments) -> BadConfig:
    beyond = station_yaml(experiments)["slide"]["options"]["max_mm"] + 10
    path = copy("displacement_sweep.yaml", lambda d: d["sweep"].update(positions_mm=[20.0, beyond, 30.0]))
    return BadConfig(path, None, path, ["field 'sweep.positions_mm[1]'", f"{beyond:g} mm", "travel",
                                        _travel(experiments)])


def range_beyond_travel(copy, tmp_path, experiments) -> BadConfig:
    below = station_yaml(experiments)["slide"]["options"]["min_mm"] - 5
    path = copy("target_heating_copper.yaml", lambda d: d["sweep"].update(start_mm=below, stop_mm=below + 80))
    return BadConfig(path, None, path, ["field 'sweep.start_mm/stop_mm[0]'", f"{below:g} mm",
                                        _travel(experiments)])


def park_beyond_travel(copy, tmp_path, experiments) -> BadConfig:
    path = copy("coil_heating.yaml", lambda d: d.update(park_mm=0.0))
    return BadConfig(path, None, path, ["field 'park_mm[0]'", "0 mm", _travel(experiments)])


def setpoint_above_safety_limit(copy, tmp_path, experiments) -> BadConfig:
    limit = station_yaml(experiments)["safety"]["max_temperature_c"]["target"]
    path = copy("target_heating_copper.yaml", lambda d: d["heating"].update(setpoints_c=[22.0, limit + 10]))
    return BadConfig(path, None, path, ["field 'heating.setpoints_c[1]'", f"{limit + 10:g} C",
                                        f"allowed below {limit:g} C", "safety.max_temperature_c"])


def power_above_heater_wiring(copy, tmp_path, experiments) -> BadConfig:
    station = station_yaml(experiments)
    volts, amps = station["safety"]["heater_max_voltage_v"], station["safety"]["heater_max_current_a"]
    max_w = min(volts ** 2 / station["heaters"]["target_heater_ohm"], volts * amps)
    powers = [0.0, 10.0, max_w * 2, 20.0]
    path = copy("target_heating_copper.yaml", lambda d: d["heating"].update(control="power", powers_w=powers))
    return BadConfig(path, None, path, ["field 'heating.powers_w[2]'", f"{max_w * 2:g} W",
                                        f"allowed 0..{max_w:.1f} W"])


def driver_in_the_wrong_role(copy, tmp_path, experiments) -> BadConfig:
    station = copy("stations/simulated_lab.yaml", lambda d: d["slide"].update(driver="hm8118"))
    return BadConfig(experiments / "displacement_sweep.yaml", station, station,
                     ["field 'slide'", "'hm8118' cannot serve as slide",
                      "allowed: " + ", ".join(drivers_for_role("slide"))])


def unknown_driver(copy, tmp_path, experiments) -> BadConfig:
    station = copy("stations/simulated_lab.yaml", lambda d: d["bridge"].update(driver="hm9999"))
    return BadConfig(experiments / "displacement_sweep.yaml", station, station,
                     ["field 'bridge.driver'", "'hm9999'", *(f"'{d}'" for d in KINDS)])


def malformed_experiment(copy, tmp_path, experiments) -> BadConfig:
    path = tmp_path / "malformed.yaml"
    path.write_text("kind: displacement_sweep\nsweep:\n  positions_mm: [20, 30\n  frequencies_hz: [500]\n")
    return BadConfig(path, None, path, ["not valid YAML", "line 4"])


def simulated_size_out_of_range(copy, tmp_path, experiments) -> BadConfig:
    station = copy("stations/simulated_lab.yaml", lambda d: d["simulated"]["lab"].update(
        imperfections={"bridge_gain_drift": {"enabled": True, "ppm_per_hour": 5e4}}))
    return BadConfig(experiments / "displacement_sweep.yaml", station, station,
                     ["field 'simulated.lab.imperfections.bridge_gain_drift.ppm_per_hour'",
                      "less than or equal to 1000", "50000"])


def simulated_object_in_the_winding(copy, tmp_path, experiments) -> BadConfig:
    station = copy("stations/simulated_lab.yaml", lambda d: d["simulated"]["lab"].update(
        imperfections={"metal_object": {"enabled": True, "radial_mm": 76.0}}))
    return BadConfig(experiments / "displacement_sweep.yaml", station, station,
                     ["imperfections.metal_object.radial_mm", "would touch the winding", "75 mm"])


def malformed_station(copy, tmp_path, experiments) -> BadConfig:
    path = tmp_path / "station.yaml"
    path.write_text("name: lab\nbridge:\n  driver: hm8118\n\tslide: {driver: grbl}\n")
    return BadConfig(experiments / "displacement_sweep.yaml", path, path, ["not valid YAML", "line 4"])


CASES: list[Callable[..., BadConfig]] = [
    unknown_key, unknown_key_in_station, wrong_type, wrong_choice, wrong_type_in_station, frequency_not_on_the_bridge,
    position_beyond_travel, range_beyond_travel, park_beyond_travel, setpoint_above_safety_limit,
    power_above_heater_wiring, driver_in_the_wrong_role, unknown_driver, malformed_experiment, malformed_station,
    simulated_size_out_of_range, simulated_object_in_the_winding,
]


@pytest.fixture(params=CASES, ids=[case.__name__ for case in CASES])
def bad_config(request, yaml_copy, tmp_path, experiments_dir) -> BadConfig:
    return request.param(yaml_copy, tmp_path, experiments_dir)


def test_run_refuses_before_touching_an_instrument(bad_config, tmp_path, instrument_guard):
    output = tmp_path / "run.h5"
    with pytest.raises(ConfigError) as refused:
        run_experiment(bad_config.experiment, bad_config.station, output, progress=False)
    message = str(refused.value)
    assert message.startswith(f"{bad_config.bad_file}:")
    for expected in bad_config.expected:
        assert expected in message
    assert instrument_guard.untouched and not output.exists()


def test_cli_exits_2_with_the_message_on_stderr(bad_config, tmp_path, instrument_guard, capsys):
    output = tmp_path / "run.h5"
    argv = ["run", str(bad_config.experiment), "-o", str(output), "-q"]
    if bad_config.station is not None:
        argv += ["--station", str(bad_config.station)]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert str(bad_config.bad_file) in captured.err
    for expected in bad_config.expected:
        assert expected in captured.err
    assert instrument_guard.untouched and not output.exists()


def test_dry_run_checks_the_files_too(bad_config, instrument_guard, capsys):
    argv = ["run", str(bad_config.experiment), "--dry-run"]
    if bad_config.station is not None:
        argv += ["--station", str(bad_config.station)]
    assert main(argv) == 2
    assert str(bad_config.bad_file) in capsys.readouterr().err and instrument_guard.untouched


def test_the_installed_command_exits_2(yaml_copy, tmp_path):
    path = yaml_copy("displacement_sweep.yaml", lambda d: d["sweep"].update(settle_sec=2.0))
    output = tmp_path / "run.h5"
    done = subprocess.run([sys.executable, "-m", "ecds_lab.cli", "run", str(path), "-o", str(output), "-q"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert f"{path}: field 'sweep.settle_sec': unknown key" in done.stderr
    assert done.stdout == "" and not output.exists()


def test_every_problem_of_a_file_is_listed(yaml_copy):
    def two_mistakes(data: dict) -> None:
        data["sweep"].update(repeats=0, frequencies_hz=[12345])

    path = yaml_copy("displacement_sweep.yaml", two_mistakes)
    with pytest.raises(ConfigError) as refused:
        prepare(path, None)
    lines = str(refused.value).splitlines()
    assert sorted(line.split("'")[1] for line in lines) == ["sweep.frequencies_hz", "sweep.repeats"]
    assert all(line.startswith(f"{path}: field ") for line in lines)


def test_the_shipped_files_are_valid(experiments_dir):
    stations = {p.name: p for p in (experiments_dir / "stations").glob("*.yaml")}
    for experiment in experiments_dir.glob("*.yaml"):
        station = stations["simulated_lab_steel.yaml"] if "steel" in experiment.name else None
        *_, plan = prepare(experiment, station)
        assert plan.points, experiment
    for station in stations.values():
        prepare(experiments_dir / "displacement_sweep.yaml", station)
