"""A campaign read at the bridge's 'medium' speed, two averages, truth a lead-screw error the start cannot test
(positions 10 mm apart): the candidates read as the campaign did (``planning.recorded_bridge``), and where one pass
of fine steps separates the rivals by less than decides, plan-next passes it as often as deciding needs
(``choice._passed_more_often``); run, the joined campaign claims the screw, its separation within a factor 3 of the
prediction."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from ecds_lab.analysis.diagnosis import Diagnosis, run_diagnosis
from ecds_lab.config.experiment import BridgeConfig
from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.station import StationConfig
from ecds_lab.model.effects import library
from ecds_lab.planning.candidates import repeated, station_candidates
from ecds_lab.planning.choice import NextPlan, plan_next, write_experiment
from ecds_lab.planning.discrimination import joined_fits, measured_separation
from ecds_lab.planning.recorded_bridge import recorded_bridge
from ecds_lab.planning.recorded_runs import recorded_runs
from ecds_lab.runner.session import run_experiment
from ecds_lab.storage.data_file import open_campaign

#: The shipped lab's lead-screw error (docs/simulated_lab.md), on the quiet lab.
SCREW = {"slide": {"lead_screw": {"enabled": True, "amplitude_um": 8.0, "pitch_mm": 5.0}}}
READ = {"speed": "medium", "averages": 2}
START = {"kind": "displacement_sweep", "name": "start", "bridge": READ,
         "sweep": {"positions_mm": [20, 30, 40, 50, 60, 70, 80, 90, 100], "frequencies_hz": [500, 15000],
                   "direction": "both", "readings_per_point": 1, "settle_s": 1.0}}


_MADE: dict[str, tuple[Path, Path, Diagnosis, NextPlan]] = {}


@pytest.fixture
def screw(truth_station, measured, tmp_path_factory) -> tuple[Path, Path, Diagnosis, NextPlan]:
    """The station, the starting run, its diagnosis and plan-next's plan (made once per test session)."""
    if "screw" not in _MADE:
        folder = tmp_path_factory.mktemp("more_passes")
        station = truth_station(folder, SCREW)
        run = measured(folder, station, START)
        opened = open_campaign([run])
        result = run_diagnosis(opened.data, (), opened.sensor)
        plan = plan_next(result, library(), load_yaml_model(station, StationConfig), runs=[run])
        _MADE["screw"] = (station, run, result, plan)
    return _MADE["screw"]


def test_the_candidates_read_as_the_campaign_did(screw):
    station, run, result, _ = screw
    recorded = recorded_bridge(recorded_runs([run]))
    assert recorded == BridgeConfig(**READ)
    config = load_yaml_model(station, StationConfig)
    as_read, _ = station_candidates(result.data, config, bridge=recorded)
    by_default, _ = station_candidates(result.data, config)
    assert as_read and all(c.experiment.bridge == recorded for c in as_read)
    assert all(c.experiment.bridge == BridgeConfig() for c in by_default)
    # two medium readings take less lab time than one slow one (the plan's estimate, runner.progress)
    fine = {c.name: c.hours for c in as_read}["fine_steps"]
    assert fine < {c.name: c.hours for c in by_default}["fine_steps"]


def test_a_csv_records_no_bridge_settings(screw, tmp_path):
    _, run, _, _ = screw
    exported = tmp_path / "start.csv"
    open_campaign([run]).data.to_csv(exported)
    assert recorded_bridge(recorded_runs([exported])) is None
    assert recorded_bridge(recorded_runs([exported, run])) == BridgeConfig(**READ)


def test_a_sweep_passed_more_often_takes_its_readings_as_often(screw):
    station, _, _, plan = screw
    config = load_yaml_model(station, StationConfig)
    fine = next(s.candidate for s in plan.scored if s.candidate.name == "fine_steps")
    thrice = repeated(fine, 3, config)
    assert thrice is not None and thrice.experiment.sweep.repeats == 3 * fine.experiment.sweep.repeats
    assert len(thrice.plan.points) == 3 * len(fine.plan.points)
    hold = next(s.candidate for s in plan.scored if s.candidate.name.startswith("coil_hold"))
    assert repeated(hold, 3, config) is None  # a hold in air has no sweep to pass again


def test_one_pass_separates_too_little_and_plan_next_passes_it_as_often_as_deciding_needs(screw):
    _, _, result, plan = screw
    assert "slide_lead_screw" in result.untestable
    index = plan.main_question
    assert plan.chosen is not None and index is not None and plan.decides, plan.why
    one = next(s for s in plan.scored if s.candidate.name == "fine_steps")
    need = plan.need(index)
    assert need / 20 <= one.guaranteed(index) < need  # the premise: one pass separates, but does not decide
    chosen = plan.chosen.candidate
    assert chosen.name.startswith("fine_steps_x") and chosen.experiment.sweep.repeats > 1
    assert chosen.experiment.bridge == BridgeConfig(**READ)
    passes = [s for s in plan.scored if s.candidate.name.startswith("fine_steps_x")]
    fewer = [s for s in passes if s.candidate.experiment.sweep.repeats < chosen.experiment.sweep.repeats]
    assert all(s.guaranteed(index) < need for s in fewer)  # the fewest passes that decide


def test_run_the_joined_campaign_claims_the_screw_within_a_factor_3_of_the_prediction(screw, tmp_path):
    station, run, _, plan = screw
    experiment = write_experiment(plan, tmp_path / "next.yaml")
    assert yaml.safe_load(experiment.read_text(encoding="utf-8"))["bridge"] == READ
    result = run_experiment(experiment, station, tmp_path / "next.h5", progress=False)
    assert result.status == "completed", result.error
    opened = open_campaign([run, tmp_path / "next.h5"])
    after = run_diagnosis(opened.data, (), opened.sensor)
    assert "slide_lead_screw" in after.claimed, after.explanation
    index = plan.main_question
    assert index is not None and plan.chosen is not None
    fits = joined_fits(plan.rivals[index], plan.questions[index].effects, after, library())
    winner, delta, _ = measured_separation(fits, after.evidence_noise)
    assert winner == "slide_lead_screw"
    at_values = plan.predicted_at_measured_values(winner, fits[winner].values)
    predicted = plan.chosen.guaranteed(index) if at_values is None else at_values
    assert predicted / 3 <= delta <= predicted * 3, (predicted, delta)


def test_a_passed_experiment_run_in_an_earlier_round_is_not_offered_again(screw):
    station, run, result, plan = screw
    assert plan.chosen is not None
    ran = plan.chosen.candidate.settings()
    again = plan_next(result, library(), load_yaml_model(station, StationConfig), done=[ran], runs=[run])
    assert all(s.candidate.settings() != ran for s in again.scored)
