"""An experiment knows its size before anything moves: bridge readings (exactly the plan's points) and a
nominal duration; plans beyond MAX_READINGS or MAX_DURATION_S are refused by the model itself."""

from __future__ import annotations

import pytest
import yaml
from pydantic import ValidationError

from ecds_lab.config.experiment import (
    EXPERIMENT_ADAPTER,
    MAX_DURATION_S,
    MAX_READINGS,
    MOVE_MM_PER_S,
    OVERHEAD_S,
    READING_S,
    PlanSize,
    SteadyState,
    format_duration,
)
from ecds_lab.runner.plan import build_plan

SHIPPED = ["displacement_sweep.yaml", "coil_heating.yaml", "spectroscopy.yaml", "target_heating_copper.yaml",
           "target_heating_steel.yaml"]


def experiment(**data):
    return EXPERIMENT_ADAPTER.validate_python(data)


def sweep(**fields) -> dict:
    return {"positions_mm": [20.0, 30.0], "frequencies_hz": [500], **fields}


HEATING = {"setpoints_c": [40.0, 60.0], "steady": {"window_s": 300, "interval_s": 10, "timeout_s": 3600},
           "cool_down_to_c": 30.0}
VARIANTS = {
    "both_directions_repeats": {"kind": "displacement_sweep", "sweep": sweep(direction="both", repeats=3,
                                                                          readings_per_point=2)},
    "range": {"kind": "displacement_sweep", "sweep": {"start_mm": 20, "stop_mm": 100, "step_mm": 2.5,
                                                    "frequencies_hz": [500, 15000], "direction": "backward"}},
    "coil_in_place": {"kind": "coil_heating", "heating": HEATING, "frequencies_hz": [500, 15000], "readings": 4},
    "coil_with_sweep": {"kind": "coil_heating", "heating": HEATING, "frequencies_hz": [500], "sweep": sweep()},
    "target": {"kind": "target_heating", "heating": HEATING, "sweep": sweep(direction="both")},
    "spectroscopy": {"kind": "spectroscopy", "frequencies_hz": [500, 1000, 15000], "coil_temperatures_c": [50, 80]},
}


@pytest.mark.parametrize("name", SHIPPED)
def test_readings_are_the_plans_points_for_the_shipped_files(name, experiments_dir):
    config = experiment(**yaml.safe_load((experiments_dir / name).read_text()))
    assert config.size().readings == len(build_plan(config).points)


@pytest.mark.parametrize("name", VARIANTS)
def test_readings_are_the_plans_points(name):
    config = experiment(**VARIANTS[name])
    assert config.size().readings == len(build_plan(config).points) > 0


def test_a_sweeps_duration_counts_settling_moves_and_readings():
    config = experiment(kind="displacement_sweep", bridge={"speed": "medium", "averages": 4},
                        sweep=sweep(positions_mm=[20.0, 50.0, 30.0], settle_s=2.0, frequencies_hz=[500, 1000]))
    reading_s = READING_S["medium"] * 4 + OVERHEAD_S
    expected = 3 * 2.0 + (30.0 + 20.0) / MOVE_MM_PER_S + 6 * reading_s
    assert config.size() == PlanSize(6, pytest.approx(expected), pytest.approx(expected))


def test_heating_takes_a_window_per_setpoint_at_least_and_its_timeouts_at_most():
    config = experiment(**VARIANTS["coil_in_place"])
    readings_s = 2 * 4 * (READING_S["slow"] + OVERHEAD_S)
    size = config.size()
    assert size.duration_s == pytest.approx(2 * readings_s + 2 * 300)
    assert size.worst_case_s == pytest.approx(2 * readings_s + 2 * 3600 + 3600)  # the cool-down's timeout too
    assert size.describe() == (f"16 bridge readings, estimated at least {format_duration(size.duration_s)}, "
                               f"up to {format_duration(size.worst_case_s)} if every heating wait runs to its timeout")


def test_the_reading_limit_is_inclusive():
    # 50 positions x 2 directions x 1000 repeats x 100 readings = MAX_READINGS exactly: refused only for its
    # duration; one position more is refused for its readings
    at_limit = sweep(positions_mm=[20.0 + i for i in range(50)], direction="both", repeats=1000,
                     readings_per_point=100, settle_s=0.0)
    assert MAX_READINGS == 50 * 2 * 1000 * 100
    with pytest.raises(ValidationError, match="takes at least") as long:
        experiment(kind="displacement_sweep", bridge={"speed": "fast"}, sweep=at_limit)
    assert "allowed: at most 7.0 days" in str(long.value)
    positions = [20.0 + i for i in range(51)]
    refused = rf"takes {51 * 2 * 1000 * 100} bridge readings \(set by sweep.positions_mm, .*\); allowed: at most"
    with pytest.raises(ValidationError, match=refused):
        experiment(kind="displacement_sweep", sweep={**at_limit, "positions_mm": positions})


def test_a_week_is_the_longest_plan():
    # settle 3600 s at each position: 167 positions fit in a week, 169 do not
    hours = int(MAX_DURATION_S // 3600)
    fits = experiment(kind="displacement_sweep",
                      sweep=sweep(positions_mm=[20.0] * (hours - 1), settle_s=3600.0))
    assert fits.size().duration_s < MAX_DURATION_S
    with pytest.raises(ValidationError, match=r"allowed: at most 7\.0 days"):
        experiment(kind="displacement_sweep", sweep=sweep(positions_mm=[20.0] * (hours + 1), settle_s=3600.0))


def test_a_window_must_hold_three_readings():
    with pytest.raises(ValidationError, match="window_s 10 s holds fewer than three readings"):
        SteadyState(window_s=10, interval_s=10)
