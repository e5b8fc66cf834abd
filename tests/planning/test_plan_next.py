"""plan-next on starting campaigns of the faithful simulated lab with a chosen truth (issue 26): it names the
experiment a physicist would choose, writes a YAML that ``run --dry-run`` and ``run`` accept unchanged, and the
Delta chi-square measured after running it is within a factor 3 of the prediction for the model that won.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from ecds_lab.analysis.diagnosis import Diagnosis, run_diagnosis
from ecds_lab.cli import main
from ecds_lab.config.loading import parse_yaml, read_text, validate
from ecds_lab.config.station import StationConfig
from ecds_lab.model.effects import library
from ecds_lab.planning.choice import NextPlan, plan_next, write_experiment
from ecds_lab.planning.discrimination import expected, joined_fits, measured_fits, measured_separation
from ecds_lab.planning.rivals import chi2_of
from ecds_lab.runner.session import run_experiment
from ecds_lab.storage.data_file import open_campaign

_PLANS: dict[tuple[Path, ...], NextPlan] = {}


def planned(station: Path, runs: list[Path]) -> NextPlan:
    """plan-next's plan for the campaign (computed once per campaign in a session: the tests only read it)."""
    key = (station, *runs)
    if key not in _PLANS:
        config = validate(str(station), parse_yaml(read_text(station), str(station)), StationConfig)
        opened = open_campaign(runs)
        _PLANS[key] = plan_next(run_diagnosis(opened.data, (), opened.sensor), library(), config, runs=runs)
    return _PLANS[key]


def test_plan_next_on_a_one_frequency_tie_names_the_other_frequency_and_writes_a_runnable_yaml(tmp_path, capsys,
                                                                                                started):
    station, run = started("a")
    output = tmp_path / "next.yaml"
    assert main(["plan-next", str(run), "--station", str(station), "-o", str(output)]) == 0
    said = capsys.readouterr().out
    assert "open question (tie)" in said and "target_bending" in said and "target_tau_temperature" in said
    text = output.read_text(encoding="utf-8")
    header = [line for line in text.splitlines() if line.startswith("#")]
    assert any("between the models" in line and "target_bending" in line and "target_tau_temperature" in line
               for line in header)
    assert any("predicted Delta chi-square" in line for line in header)
    assert any(line.startswith("# Lab time") and " h." in line for line in header)
    # the target's waits are predicted from the start's recorded ones (docs/planning.md, Predicted readings)
    assert any(line.startswith("# Heater waits predicted from the campaign's recorded ones: target:")
               for line in header)
    experiment = yaml.safe_load(text)
    assert experiment["kind"] == "target_heating"
    assert 15000.0 not in experiment["sweep"]["frequencies_hz"]  # the other frequency, with the target hot
    assert max(experiment["heating"]["setpoints_c"]) >= 70.0
    assert main(["run", str(output), "--station", str(station), "--dry-run"]) == 0
    capsys.readouterr()
    assert main(["plan-next", str(run), "--station", str(station), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert {"open_questions", "rivals", "candidates", "refused", "not_asked", "unanswerable", "decided", "chosen",
            "why", "predicted_delta_chi2"} <= set(printed)
    assert printed["chosen"]["name"] == yaml_name(text) and printed["predicted_delta_chi2"] >= 25.0
    assert [line.split(":")[0] for line in printed["heater_waits"]] == ["target"]
    assert main(["run", str(output), "--station", str(station), "-o", str(tmp_path / "next.h5"), "-q"]) == 0


def yaml_name(text: str) -> str:
    """The candidate name a written experiment came from, by its experiment name (``target at 75 C, 500 Hz``)."""
    frequency = yaml.safe_load(text)["sweep"]["frequencies_hz"][0]
    return f"target_hot_{frequency:g}hz"


def test_the_one_direction_start_claims_tau_x_and_the_bending_and_leaves_the_backlash_open(started):
    # case (c): alone, tau_T(x) leaves the bending's hot-cold shift (109 ppm) and the bending tau_T(x)'s 500/15000 Hz
    # difference (198 ppm); each knot of tau_T(x) trades with tau_T and C_p (+-1 to 1.7 in ln) while the curve is
    # known, and the bending's linear and quadratic terms trade (the curvature seen only on the heating log at
    # 100 mm) while the shift they make is known: judged as a whole, both are claimed, and the model is at the noise
    _, run = started("c")
    opened = open_campaign([run])
    result = run_diagnosis(opened.data, (), opened.sensor)
    assert {"tau_displacement", "target_bending"} <= set(result.claimed), result.explanation
    assert result.final.rmse_ppm < 1.2 * result.noise_ppm
    assert "slide_backlash" in result.untestable  # one direction: only an offset the calibration takes


#: case -> what a physicist would choose, as a test on the chosen experiment's settings
PHYSICIST = {
    "a": lambda s: s["kind"] == "target_heating" and 15000.0 not in s["sweep"]["frequencies_hz"],
    "b": lambda s: s["kind"] == "target_heating" and 15000.0 not in s["sweep"]["frequencies_hz"],
    "c": lambda s: s["sweep"]["direction"] == "both",
}


@pytest.mark.parametrize("case", ["a", "b", "c"])
def test_plan_next_names_the_experiment_a_physicist_would_choose(case, started):
    station, run = started(case)
    plan = planned(station, [run])
    assert plan.chosen is not None and plan.decides, plan.why
    assert PHYSICIST[case](plan.chosen.candidate.settings()), plan.chosen.candidate.what


def test_plan_next_on_d_has_no_drying_or_lag_to_decide(started):
    """Case (d), the coil heated in air at 500 Hz and 15 kHz, truth a moist former: the drying, with the winding's
    swelling, takes the start to its noise (1533 -> 20.0 ppm, 1.06x; strain 142 ppm against the documented 150,
    capacitance 14.3 pF against 15). Before the library had the swelling, the drying left 36 ppm and the winding's
    lag took part of it with its size 2.8 standard errors from zero, so plan-next asked the lag's size (and chose the
    ramps, where a hold was expected): the lag's evidence was the swelling's. Nothing is left to decide between
    the drying and the lag; what is left (the former's expansion, which needs the target in place) this station
    cannot answer."""
    station, run = started("d")
    plan = planned(station, [run])
    assert not [q for q in plan.questions if q.kind in ("tie", "undetermined")], plan.questions
    assert plan.chosen is None and plan.why.startswith("no open question this station can answer"), plan.why


_AFTER: dict[tuple[Path, ...], Diagnosis] = {}


def diagnosed_after(station: Path, run: Path, folder: Path) -> tuple[NextPlan, Diagnosis]:
    """The plan, run on the station, and the joined campaign's diagnosis (once per campaign in a session)."""
    plan = planned(station, [run])
    assert plan.chosen is not None and plan.decides, plan.why
    key = (station, run)
    if key not in _AFTER:
        experiment = write_experiment(plan, folder / "next.yaml")
        result = run_experiment(experiment, station, folder / "next.h5", progress=False)
        assert result.status == "completed", result.error
        opened = open_campaign([run, folder / "next.h5"])
        _AFTER[key] = run_diagnosis(opened.data, (), opened.sensor)
    return plan, _AFTER[key]


def predicted_for(plan: NextPlan, winner: str, values: dict[str, float]) -> tuple[float | None, float | None]:
    """The prediction the choice was made on had ``winner`` been the truth (at a nested rival's hypothetical size),
    and the figure the measured separation is held to: the same T-criterion at the size the run measured when the
    winner supposed one."""
    index = plan.main_question
    assert plan.chosen is not None and index is not None
    as_planned = expected(plan.chosen.separations[index], winner)
    at_size = plan.predicted_at_measured_size(winner, values)
    return as_planned, as_planned if at_size is None else at_size


@pytest.mark.parametrize("case", [
    "a",
    pytest.param("b", marks=pytest.mark.xfail(strict=True, reason=(
        "the starting diagnosis ties target_bending with target_tau_temperature; plan-next names the target hot at "
        "500 Hz (56.9 predicted if the conductivity change is true, the least over the plate thicknesses the start "
        "allows; 70196 at its fitted 1.07 mm), but neither rival fits the joined campaign (chi-square 3057 and 3050 "
        "over 110 readings; neither holds tau_T(x), which takes the joined campaign's baseline from 205 to 128 "
        "ppm), so they differ by 7.3; with tau_T(x) in both (the next test) 226.5"))),
    "c"])
def test_the_measured_separation_is_within_a_factor_3_of_the_prediction(case, tmp_path, started):
    station, run = started(case)
    plan, after = diagnosed_after(station, run, tmp_path)
    index = plan.main_question
    # in the noise the prediction is stated in: the diagnosis's evidence noise (its reported noise is re-estimated on
    # its final model, docs/diagnosis.md)
    fits = measured_fits(plan.rivals[index], after.data, after.evidence_noise)
    chi2 = {label: chi2_of(fit, after.evidence_noise) for label, fit in fits.items()}
    winner = min(chi2, key=chi2.__getitem__)
    delta = sorted(chi2.values())[1] - chi2[winner]
    as_planned, predicted = predicted_for(plan, winner, fits[winner].values)
    assert predicted is not None and predicted > 0
    assert predicted / 3 <= delta <= predicted * 3, (winner, predicted, delta, as_planned)


@pytest.mark.parametrize("case", ["a", "b", "c"])
def test_the_separation_measured_with_what_the_joined_campaign_needs_is_within_a_factor_3(case, tmp_path, started):
    """The measured separation investigate records: each rival fitted to the joined campaign together with what its
    diagnosis needs beyond the question (``discrimination.joined_fits``), so a misfit both share does not count;
    held to the prediction with every value the winner supposed (a hypothetical size, a parameter the start's rules
    held because it could not determine it) at the joined campaign's (``discrimination.at_measured_values``)."""
    station, run = started(case)
    plan, after = diagnosed_after(station, run, tmp_path)
    index = plan.main_question
    fits = joined_fits(plan.rivals[index], plan.questions[index].effects, after, library())
    winner, delta, chi2 = measured_separation(fits, after.evidence_noise)
    as_planned, _ = predicted_for(plan, winner, fits[winner].values)
    at_values = plan.predicted_at_measured_values(winner, fits[winner].values)
    predicted = as_planned if at_values is None else at_values
    assert predicted is not None and predicted > 0
    assert predicted / 3 <= delta <= predicted * 3, (winner, predicted, delta, as_planned, chi2)


def test_a_shape_parameter_the_start_leaves_flat_is_taken_over_its_plausible_range(tmp_path, started):
    """Case (b): one frequency leaves the conductivity change's plate thickness flat (its linearised standard error
    0.45 mm at 1.07 mm); its profile interval on the start (Delta chi-square <= 1) holds the thickness the joined
    campaign finds, every point of it fits the start within 1 noise variance, and the prediction is the least
    over it, the figure at the fit kept beside (``Separation.at_fit``)."""
    station, run = started("b")
    plan, after = diagnosed_after(station, run, tmp_path)
    index = plan.main_question
    assert plan.chosen is not None and index is not None
    rival = next(r for r in plan.rivals[index] if r.label == "target_tau_temperature")
    low, high = rival.plausible_ranges["plate_thickness"]
    assert all(v.chi2 - rival.chi2 <= 1.0 for v in rival.plausible)
    fits = joined_fits(plan.rivals[index], plan.questions[index].effects, after, library())
    assert low <= fits["target_tau_temperature"].values["plate_thickness"] <= high, (low, high)
    assert low <= after.final.fit.values["plate_thickness"] <= high, (low, high)
    separation = next(s for s in plan.chosen.separations[index] if s.truth == "target_tau_temperature")
    assert separation.at_fit is not None and separation.delta_chi2 <= separation.at_fit.delta_chi2
    assert separation.guaranteed <= separation.at_fit.guaranteed


def test_plan_next_outside_the_library_designs_nothing_and_says_where_the_residual_lives(tmp_path, capsys, started):
    station, run = started("e")
    output = tmp_path / "next.yaml"
    assert main(["plan-next", str(run), "--station", str(station), "-o", str(output)]) == 0
    said = capsys.readouterr().out
    assert "no experiment can make a library effect explain the residual" in said
    assert "x_mm" in said.split("no experiment can make")[1]
    assert not output.exists()


def test_every_candidate_keeps_inside_tight_station_limits(tight_limits):
    station, run = tight_limits
    plan = planned(station, [run])
    assert plan.scored, plan.refused
    for scored in plan.scored:
        settings = scored.candidate.settings()
        sweep = settings.get("sweep", {})
        assert all(20.0 <= x <= 90.0 for x in sweep.get("positions_mm", [])), settings
        assert settings.get("park_mm", 0.0) <= 90.0
        limit = 60.0 if settings["kind"] == "target_heating" else 50.0
        assert all(t < limit for t in settings.get("heating", {}).get("setpoints_c", [])), settings
    config = validate(str(station), parse_yaml(read_text(station), str(station)), StationConfig)
    opened = open_campaign([run])
    short = plan_next(run_diagnosis(opened.data, (), opened.sensor), library(), config, max_hours=0.1)
    assert all(s.candidate.hours <= 0.1 for s in short.scored)
    assert any("more than the 0.1 h allowed" in why for why in short.refused.values())


def test_a_tie_the_campaign_decides_already_is_not_designed_for():
    """A contested claim is judged in its own round; once a later effect takes its share the rival may fit the
    campaign far worse than the diagnosis's final model: then the campaign decides it (chi-square in noise
    variances, DECISIVE_CHI2 = 25), and nothing is designed for it. Within the margin, or with the rival ahead, the
    question stays open; a question that is not a tie is never decided this way."""
    from types import SimpleNamespace

    from ecds_lab.planning.choice import decided_by_campaign
    from ecds_lab.planning.questions import OpenQuestion
    from ecds_lab.planning.rivals import Rival

    final = ("tau_displacement", "target_tau_temperature")
    result = SimpleNamespace(final=SimpleNamespace(effects=list(final)))
    tie = OpenQuestion("tie", ("tau_displacement", "target_bending"), "which of tau_displacement or target_bending")

    def rivals(held: float, other: float) -> list[Rival]:
        return [Rival("tau_displacement", final, None, {}, held),  # type: ignore[arg-type]
                Rival("target_bending", ("target_bending", "target_tau_temperature"), None, {}, other)]  # type: ignore[arg-type]

    why = decided_by_campaign(tie, rivals(130.2, 4403.5), result)  # type: ignore[arg-type]
    assert why is not None and "tau_displacement" in why and "4273.3" in why
    assert decided_by_campaign(tie, rivals(130.2, 150.0), result) is None  # type: ignore[arg-type]
    assert decided_by_campaign(tie, rivals(4403.5, 130.2), result) is None  # type: ignore[arg-type]
    backlash = OpenQuestion("not_excluded", ("slide_backlash",), "is slide_backlash present")
    assert decided_by_campaign(backlash, rivals(130.2, 4403.5), result) is None  # type: ignore[arg-type]
