"""Plans: the points an experiment measures, position ranges, and the heater waits they hold."""

from __future__ import annotations

import itertools

import pytest

from ecds_lab.config.experiment import SweepConfig
from ecds_lab.runner.plan import build_plan
from ecds_lab.runner.session import load_experiment
from ecds_lab.runner.steps import CoolDown, SetHeater, WaitSteady


def test_displacement_plan_is_positions_x_frequencies_x_directions_x_readings(experiments_dir):
    experiment = load_experiment(experiments_dir / "displacement_sweep.yaml")
    sweep = experiment.sweep
    assert len(sweep.positions()) == 31 and sweep.direction == "both"
    plan = build_plan(experiment)
    points = plan.points
    assert len(points) == 31 * len(sweep.frequencies_hz) * 2 * sweep.readings_per_point * sweep.repeats
    assert [p.point for p in points] == list(range(len(points)))
    # forward over the positions, then backward; every frequency and reading at each position
    forward = [p for p in points if p.direction == "forward"]
    backward = [p for p in points if p.direction == "backward"]
    assert len(forward) == len(backward) and forward[-1].point < backward[0].point
    assert list(dict.fromkeys(p.x_mm for p in forward)) == sweep.positions()
    assert list(dict.fromkeys(p.x_mm for p in backward)) == sweep.positions()[::-1]
    at_first = [(p.freq_hz, p.reading) for p in forward if p.x_mm == sweep.positions()[0]]
    assert sorted(at_first) == sorted((f, r) for f in sweep.frequencies_hz for r in range(sweep.readings_per_point))
    assert plan.describe().splitlines()[0].endswith(f"{len(plan.steps)} steps, {len(points)} planned readings")


@pytest.mark.parametrize("start, stop, step", [(20.0, 100.0, 10.0), (20.0, 21.0, 0.1), (100.0, 20.0, 10.0),
                                               (30.0, 30.0, 5.0)])
def test_start_stop_step_is_inclusive(start, stop, step):
    positions = SweepConfig(start_mm=start, stop_mm=stop, step_mm=step, frequencies_hz=[500]).positions()
    assert positions[0] == start and positions[-1] == stop
    assert len(positions) == round(abs(stop - start) / step) + 1
    gaps = [abs(b - a) for a, b in itertools.pairwise(positions)]
    assert gaps == pytest.approx([step] * len(gaps))


def test_a_step_that_does_not_divide_the_range_is_refused():
    with pytest.raises(ValueError, match=r"step_mm 3 does not divide .*allowed: .*2\.5"):
        SweepConfig(start_mm=20, stop_mm=25, step_mm=3, frequencies_hz=[500])


def test_target_heating_plan_sweeps_at_every_setpoint(experiments_dir):
    experiment = load_experiment(experiments_dir / "target_heating_copper.yaml")
    plan = build_plan(experiment)
    per_sweep = len(experiment.sweep.positions()) * len(experiment.sweep.frequencies_hz)
    assert len(plan.points) == per_sweep * len(experiment.heating.setpoints_c)
    waits = [s for s in plan.steps if isinstance(s, WaitSteady)]
    assert [w.setpoint_c for w in waits] == experiment.heating.setpoints_c
    assert isinstance(plan.steps[-2], SetHeater) and plan.steps[-2].setpoint_c is None  # heater off, then cool
    assert isinstance(plan.steps[-1], CoolDown) and plan.steps[-1].below_c == experiment.heating.cool_down_to_c


def test_spectroscopy_waits_hold_the_configured_criterion_and_log_nothing(experiments_dir):
    experiment = load_experiment(experiments_dir / "spectroscopy.yaml")
    waits = [s for s in build_plan(experiment).steps if isinstance(s, WaitSteady)]
    assert [w.setpoint_c for w in waits] == experiment.coil_temperatures_c
    config = experiment.heating
    for wait in waits:
        assert wait.log is None
        assert (wait.steady.slope_k_per_min, wait.steady.window_s, wait.steady.tolerance_k,
                wait.steady.check_interval_s, wait.steady.timeout_s) == (
            config.slope_k_per_min, config.window_s, config.tolerance_k, config.interval_s, config.timeout_s)
        assert wait.describe().endswith("; no bridge readings")


def test_heating_waits_log_the_bridge_at_the_configured_frequencies(experiments_dir):
    experiment = load_experiment(experiments_dir / "target_heating_copper.yaml")
    plan = build_plan(experiment)
    waits = [s for s in plan.steps if isinstance(s, (WaitSteady, CoolDown))]
    expected = tuple(experiment.heating.log_frequencies_hz or experiment.sweep.frequencies_hz)
    assert all(w.log is not None and w.log.frequencies_hz == expected
               and w.log.interval_s == experiment.heating.log_interval_s for w in waits)
    assert "1e+09" not in plan.describe()
