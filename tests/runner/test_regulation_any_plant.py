"""Issue 24 point 11: the heater loop runs through a sweep at a setpoint, the hold is recorded and judged, and a
step response identifies a new plant: simulated plants 5x faster and 5x slower than the shipped lab's hold every
setpoint through the sweep without tripping the interlock."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import h5py
import pytest

from ecds_lab.cli import main
from ecds_lab.config.experiment import EXPERIMENT_ADAPTER
from ecds_lab.config.station import RegulationConfig, SimulationConfig, StationConfig
from ecds_lab.data.columns import PLANNED_POINT
from ecds_lab.runner.plan import Plan, build_plan
from ecds_lab.runner.runner import Runner
from ecds_lab.runner.session import run_experiment
from ecds_lab.runner.steps import CheckHold, ConfigureScanner, IdentifyPlant, SetHeater
from ecds_lab.simulators.config import LabConfig, Thermal
from ecds_lab.station import open_station

SETPOINTS_C = [45.0, 90.0]
TOLERANCE_K = 1.0
#: The shipped lab's thermal time constants (simulators/config.py Thermal), scaled per plant.
TODAY = {"target_tau_s": 600.0, "box_tau_s": 120.0, "former_tau_s": 900.0}


def experiment(heater: str) -> dict:
    heating = {"setpoints_c": SETPOINTS_C, "steady": {"interval_s": 10, "window_s": 300, "tolerance_k": TOLERANCE_K}}
    sweep = {"start_mm": 20, "stop_mm": 100, "step_mm": 20, "frequencies_hz": [500, 15000], "settle_s": 10,
             "readings_per_point": 5}
    if heater == "target":
        return {"kind": "target_heating", "heating": heating, "sweep": sweep}
    return {"kind": "coil_heating", "frequencies_hz": [500, 15000], "heating": heating, "sweep": sweep}


def station(factor: float, regulation: RegulationConfig) -> StationConfig:
    thermal = Thermal(**{name: tau * factor for name, tau in TODAY.items()})
    return StationConfig(simulated=SimulationConfig(lab=LabConfig(thermal=thermal, physics="field"), pacing=False),
                         regulation=regulation)


def run_plan(config: StationConfig, plan: Plan, rows_in_memory) -> tuple[str, str, Runner]:
    opened = open_station(config)
    try:
        runner = Runner(opened, plan, rows_in_memory, progress=False)
        status, error = runner.run()
    finally:
        opened.close()
    return status, error, runner


@pytest.mark.parametrize(("factor", "heater"), [
    pytest.param(0.2, "target", id="5x faster-target"), pytest.param(5.0, "target", id="5x slower-target"),
    pytest.param(0.2, "coil", id="5x faster-coil"),
    pytest.param(5.0, "coil", id="5x slower-coil")])
def test_plants_5x_faster_and_slower_hold_every_setpoint_through_the_sweep(factor, heater, rows_in_memory):
    regulation = RegulationConfig()  # identification on, as for any new station
    config = station(factor, regulation)
    plan = build_plan(EXPERIMENT_ADAPTER.validate_python(experiment(heater)), regulation=regulation)
    status, error, runner = run_plan(config, plan, rows_in_memory)

    assert status == "completed", error
    column = f"t_{heater}_c"
    assert max(row[column] for row in rows_in_memory.rows) < config.safety.max_temperature_c[heater]
    points = [row for row in rows_in_memory.rows if row["kind"] == PLANNED_POINT]
    sweeps = [list(rows) for _, rows in itertools.groupby(points, key=lambda row: row["sweep"])]
    assert len(sweeps) == len(SETPOINTS_C)
    for setpoint, rows in zip(SETPOINTS_C, sweeps, strict=True):
        worst = max(abs(row[column] - setpoint) for row in rows)
        assert worst <= TOLERANCE_K, (setpoint, worst)
    assert runner.context is not None
    assert [hold.setpoint_c for hold in runner.context.holds] == SETPOINTS_C
    assert all(hold.within_tolerance for hold in runner.context.holds), [h.describe() for h in runner.context.holds]
    assert set(runner.context.identified) == {heater}


def test_the_heater_loop_runs_between_the_readings_of_a_sweep(rows_in_memory):
    """Before: the supply kept its last output from the end of the wait to the end of the sweep."""
    regulation = RegulationConfig(identify={"enabled": False})
    plan = build_plan(EXPERIMENT_ADAPTER.validate_python(experiment("target")), regulation=regulation)
    opened = open_station(station(1.0, regulation))
    try:
        runner = Runner(opened, plan, rows_in_memory, progress=False)
        status, error = runner.run()
        events = opened.transports["heater"].transcript.events
    finally:
        opened.close()
    assert status == "completed", error
    first_sweep = [row["time_s"] for row in rows_in_memory.rows if row["kind"] == PLANNED_POINT and row["sweep"] == 0]
    start, end = first_sweep[0], first_sweep[-1]
    assert end - start > 60.0
    volts = [e.clock_s - runner.t0 for e in events if e.text.startswith("VOLT ")]
    during = [t for t in volts if start <= t <= end]
    assert len(during) >= (end - start) / 10.0 - 2, (len(during), start, end)  # one per 10 s control period


def test_the_identification_is_a_plan_step_before_the_first_setpoint_and_shown_in_the_dry_run():
    plan = build_plan(EXPERIMENT_ADAPTER.validate_python(experiment("target")), regulation=RegulationConfig())
    kinds = [type(step) for step in plan.steps]
    first_setpoint = next(i for i, s in enumerate(plan.steps) if isinstance(s, SetHeater) and s.setpoint_c)
    assert kinds.index(IdentifyPlant) == first_setpoint - 1 and kinds.count(IdentifyPlant) == 1
    assert "identify the target heater: 20% of its power until it rises 3 K" in plan.describe()
    assert kinds.count(CheckHold) == len(SETPOINTS_C)
    off = build_plan(EXPERIMENT_ADAPTER.validate_python(experiment("target")),
                     regulation=RegulationConfig(identify={"enabled": False}))
    assert IdentifyPlant not in [type(step) for step in off.steps]


def test_the_identification_stops_short_of_the_over_temperature_limit_and_leaves_the_heater_off(rows_in_memory):
    config = station(0.2, RegulationConfig())
    safety = config.safety.model_copy(update={"max_temperature_c": {"target": 34.0}})
    config = config.model_copy(update={"safety": safety})
    step = IdentifyPlant("target", step_fraction=0.5, rise_k=20.0, margin_k=10.0, check_interval_s=10.0,
                         timeout_s=3600.0)
    opened = open_station(config)
    try:
        runner = Runner(opened, Plan("identify", "test", (ConfigureScanner(), step)), rows_in_memory, progress=False)
        status, error = runner.run()
        assert opened.lab is not None
        output_on = opened.lab.supply[config.heaters.target_output].on
    finally:
        opened.close()
    assert status == "completed", error
    assert runner.context is not None
    identified = runner.context.identified["target"]
    assert identified["peak_c"] < 34.0 and not output_on  # stopped at the margin, far short of +20 K
    assert identified["peak_c"] - identified["baseline_c"] < 10.0  # half the 20 K the step asked for


def test_the_run_file_records_each_hold_with_units(tmp_path, experiments_dir):
    out = tmp_path / "run.h5"
    result = run_experiment(experiments_dir.parent / "tests/data/sessions/heating.yaml", None, out, progress=False)
    assert result.status == "completed", result.error
    with h5py.File(out, "r") as f:
        holds = json.loads(f["entry"].attrs["temperature_holds"])
        units = json.loads(f["entry"].attrs["temperature_holds_units"])
    assert [hold["setpoint_c"] for hold in holds] == [26.0, 30.0]
    assert units["drift_k"] == "K" and units["t_min_c"] == "degC"
    assert all(hold["samples"] > 3 and abs(hold["drift_k"]) <= hold["t_max_c"] - hold["t_min_c"] + 1e-12
               for hold in holds)


def test_a_new_station_identifies_its_heater_in_the_dry_run_the_run_file_and_the_cli(tmp_path, yaml_copy, capsys):
    """A station that leaves identification on (as any new station does) shows the step in --dry-run, and the run
    prints and records the identified plant and gains."""
    station_path = yaml_copy("stations/simulated_lab.yaml", lambda d: d.pop("regulation"), name="new_lab.yaml")
    experiment_path = Path(__file__).parents[1] / "data" / "sessions" / "heating.yaml"
    assert main(["run", str(experiment_path), "--station", str(station_path), "--dry-run"]) == 0
    plan_text = capsys.readouterr().out
    assert "identify the target heater" in plan_text and "1 IdentifyPlant" in plan_text
    out = tmp_path / "run.h5"
    assert main(["run", str(experiment_path), "--station", str(station_path), "-o", str(out), "-q"]) == 0
    printed = capsys.readouterr().out
    assert "target heater identified:" in printed and "Kp" in printed
    with h5py.File(out, "r") as f:
        identified = json.loads(f["entry"].attrs["heater_identification"])
    assert set(identified) == {"target"} and identified["target"]["kp_w_per_k"] > 0
    assert identified["target"]["peak_c"] < 140.0


def test_a_hotter_faster_plant_trips_the_interlock_with_fixed_gains_and_holds_once_identified(rows_in_memory):
    """The issue's other failure: fixed gains drove an unknown plant into the over-temperature interlock. A target
    of 5 K/W (five times the shipped lab's) with 5x faster time constants, heated to 130 C: the station's fixed
    gains overshoot past the 140 C limit (before this branch too: 140.9 C); identified gains hold every setpoint."""
    setpoints = [45.0, 90.0, 130.0]
    thermal = Thermal(**{name: tau * 0.2 for name, tau in TODAY.items()}, target_k_per_w=5.0)
    spec = experiment("target")
    spec["heating"]["setpoints_c"] = setpoints
    results = {}
    for identify in (False, True):
        regulation = RegulationConfig(identify={"enabled": identify})
        lab = LabConfig(thermal=thermal, physics="field")
        config = StationConfig(simulated=SimulationConfig(lab=lab, pacing=False), regulation=regulation)
        rows_in_memory.rows.clear()
        plan = build_plan(EXPERIMENT_ADAPTER.validate_python(spec), regulation=regulation)
        status, error, runner = run_plan(config, plan, rows_in_memory)
        results[identify] = (status, error, runner, max(row["t_target_c"] for row in rows_in_memory.rows))
    status, error, _, _ = results[False]
    assert status == "failed" and "SafetyInterlock: target thermocouple reads" in error
    status, error, runner, hottest = results[True]
    assert status == "completed", error
    assert runner.context is not None and [h.setpoint_c for h in runner.context.holds] == setpoints
    assert all(hold.within_tolerance for hold in runner.context.holds)
    assert hottest < 140.0
