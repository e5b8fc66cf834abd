"""The search of the diagnosis on the faithful lab (physics: field), one campaign per class of issue 23
(1: a tie does not end the search; 3: what one frequency can tell; 4: no silent cap; 6: the lead screw
over its whole range) and issue 24 point 6 (advice that knows the campaign). Each asserts the right
behaviour and that nothing false is claimed."""

from __future__ import annotations

import dataclasses
import json
import traceback
import types

import numpy as np
import pytest

from ecds_lab import forked
from ecds_lab.analysis.diagnosis import run_diagnosis, search
from ecds_lab.analysis.diagnosis.advice import Design
from ecds_lab.analysis.diagnosis.checks import at_bound
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.library.parasitic_capacitance import ParasiticCapacitance
from ecds_lab.model.library.slide_backlash import SlideBacklash
from ecds_lab.simulators import campaign

POSITIONS_MM = (25.0, 30.0, 40.0, 50.0, 60.0, 70.0, 85.0, 100.0)
#: The field solution's own change of tau_T with distance: a true finding wherever the data can test it.
FIELD_SOLUTION = "tau_displacement"


def one_frequency_heating(lab, freq_hz: float, directions=("forward", "backward"), setpoints=(70, 120)):
    """A room-temperature sweep and target-heated sweeps at one frequency (a few hundred readings)."""
    room = campaign.displacement_sweep(lab, POSITIONS_MM, (freq_hz,), directions=directions, repeats=2)
    hot = campaign.target_heating(lab, setpoints, positions_mm=POSITIONS_MM, frequencies_hz=(freq_hz,),
                                  directions=directions, repeats=2)
    return Measurements.concatenate([room, hot])


def assert_no_single_member_groups(result) -> None:
    assert all(len(group) >= 2 for group in result.alternatives), result.alternatives
    assert all(len(group) >= 2 for group in result.to_json()["alternatives"])


# -- class 1: a tie does not end the search --------------------------------------------------------------
def test_a_backlash_beside_a_bending_or_conductivity_tie_is_still_found(field_lab):
    lab = field_lab(plate={"bending": {"enabled": True}}, slide={"backlash": {"enabled": True, "backlash_um": 30.0}})
    result = run_diagnosis(one_frequency_heating(lab, 15000.0))
    assert "slide_backlash" in result.claimed, result.explanation
    assert any({"target_bending", "target_tau_temperature"} <= set(g) for g in result.alternatives), result.explanation
    assert not {"target_bending", "target_tau_temperature"} & set(result.claimed)  # the tie is not a claim
    assert set(result.claimed) <= {"slide_backlash", FIELD_SOLUTION}, result.explanation
    assert_no_single_member_groups(result)
    assert result.final.fit.values["backlash"] == pytest.approx(30e-6, rel=0.3)
    assert "cannot tell" in result.explanation and "Adding slide_backlash" in result.explanation


def test_a_drift_no_library_effect_describes_is_outside_the_library_not_a_tie(field_campaign):
    """The bridge's gain drifting slowly with time (400 ppm over the campaign): it lives in time."""
    data = field_campaign(frequencies_hz=(15000.0,))
    span = np.ptp(data.time_s)
    data = dataclasses.replace(data, ls_h=data.ls_h * (1 + 400e-6 * (data.time_s - data.time_s.min()) / span))
    result = run_diagnosis(data)
    assert result.verdict == "missing_effect", result.explanation
    assert result.alternatives == [], result.explanation
    assert "outside the library" in result.explanation
    time = next(a for a in result.associations if a.variable == "time_s")
    assert time.significance > 8  # structure in time within the campaign's phases
    assert set(result.claimed) <= {FIELD_SOLUTION}, result.explanation


# -- class 3: what one frequency can tell ------------------------------------------------------------------
def test_at_one_frequency_tau_of_x_is_untestable_from_the_data(field_lab):
    """The calibration absorbs any tau_T(x) at one frequency: decided from the Jacobian, not by a rule."""
    lab = field_lab(plate={"conductivity": {"enabled": True}})
    result = run_diagnosis(one_frequency_heating(lab, 15000.0, directions=("forward",)))
    assert FIELD_SOLUTION not in result.claimed, result.explanation
    assert "absorbed by the calibration" in result.untestable[FIELD_SOLUTION]
    assert "target_bending" not in result.claimed


# -- class 4: no silent cap ---------------------------------------------------------------------------------
def test_a_limit_reached_is_said_with_what_was_left_untested(field_campaign):
    data = field_campaign(plate={"bending": {"enabled": True}}, slide={"backlash": {"enabled": True}})
    result = run_diagnosis(data, max_steps=1)
    report = result.to_json()
    assert len(result.claimed) == 1
    assert report["limits_reached"] and "max_steps" in report["limits_reached"][0]
    assert set(report["untested"]) >= {"slide_backlash", "target_bending"} - set(result.claimed)
    assert "outside the library" not in report["explanation"]
    assert "max_steps" in report["explanation"]
    json.dumps(report)


def test_on_a_1_mm_plate_tau_of_x_joins_the_conductivity_change_and_nothing_false(field_campaign):
    """A 1 mm copper plate heated, two frequencies: tau(x)'s range once set for a thick plate refused it, and a
    thickness settled alone in the thick valley left room for a false bending. Refitting the earlier effects
    from their alternative starts once tau(x) joins finds the thin plate."""
    data = field_campaign(plate={"thickness_m": 1e-3, "conductivity": {"enabled": True}})
    result = run_diagnosis(data)
    assert result.claimed == ["target_tau_temperature", FIELD_SOLUTION], result.explanation
    assert result.final.fit.values["plate_thickness"] == pytest.approx(1e-3, rel=0.3)
    assert result.final.rmse_ppm <= 1.5 * result.noise_ppm


# -- class 6: the lead screw over its whole declared range ----------------------------------------------------
def test_a_long_lead_is_found_by_the_scan_over_leads(faithful_sweep_with):
    result = run_diagnosis(faithful_sweep_with(1, screw_um=12.0, lead_mm=17.0))
    assert "slide_lead_screw" in result.claimed, result.explanation
    values = result.final.fit.values
    assert values["screw_lead"] == pytest.approx(17e-3, abs=0.5e-3)
    assert np.hypot(values["screw_sin"], values["screw_cos"]) == pytest.approx(12e-6, rel=0.25)
    assert set(result.claimed) <= {"slide_lead_screw", FIELD_SOLUTION}, result.explanation


# -- issue 24 point 6: advice that knows the campaign ----------------------------------------------------------
def test_advice_never_asks_for_what_the_campaign_already_holds(field_lab):
    lab = field_lab(plate={"bending": {"enabled": True}})
    data = one_frequency_heating(lab, 500.0, directions=("forward",), setpoints=(120,))
    result = run_diagnosis(data)
    assert not result.claimed or set(result.claimed) <= {FIELD_SOLUTION}, result.explanation
    assert result.suggested_measurements, result.explanation
    assert not any("500 Hz as well" in s for s in result.suggested_measurements), result.suggested_measurements
    assert any("15000 Hz as well" in s for s in result.suggested_measurements), result.suggested_measurements
    design = Design.of(data)
    assert design.present_hz == (500.0,) and design.directions == 1
    assert not design.meets({"frequencies_target_hot": 2}) and design.meets({"target_span_k": 50.0})


# -- a round on the same model and readings reuses the fits made for it ------------------------------------------
@pytest.fixture
def drying_judged_where_hottest(monkeypatch):
    """The drying's course judged by its rate where the coil is hottest, as the library did before it judged it
    where the former dries (``ParasiticCapacitance.drying_temperature``): a subsample of a hundred readings leaves
    that rate open, which these tests of the search's handling of an open course need (where the former dries,
    30 readings of the drying campaign determine it already)."""
    monkeypatch.setattr(ParasiticCapacitance, "drying_temperature",
                        lambda self, data, values: float(data.t_coil_c.max()))


def test_a_round_weighing_the_same_model_again_reuses_its_fits_and_answers_alike(campaign_with, monkeypatch,
                                                                              drying_judged_where_hottest):
    """The drying campaign screened at 100 readings: a claim fails its checks on every reading and is dropped,
    which leaves the model as it was, and the round after it weighs the same candidates on the same readings.
    Reusing the fits made for it (``_RoundWork``) gives the answer a round from scratch gives, with fewer fits."""
    data = campaign_with("parasitic_capacitance")
    fits, confirmations = [], []
    real_candidate, real_round, real_confirmed = search._candidate, search._round, search._confirmed

    def counted(*args, **kwargs):
        fits.append(1)
        return real_candidate(*args, **kwargs)

    def confirmed(*args, **kwargs):
        confirmations.append(real_confirmed(*args, **kwargs))
        return confirmations[-1]

    monkeypatch.setattr(search, "_candidate", counted)
    monkeypatch.setattr(search, "_confirmed", confirmed)
    reused = run_diagnosis(data, screen_rows=100)
    with_work = len(fits)
    fits.clear()
    monkeypatch.setattr(search, "_round", lambda *args, **kwargs: real_round(*args[:8], **{**kwargs, "work": None}))
    anew = run_diagnosis(data, screen_rows=100)
    assert any(not c.passes for c in confirmations)  # a claim was dropped on every reading
    assert reused.to_json() == anew.to_json()
    assert with_work < len(fits)


# -- the held-out check's margin, in noise units --------------------------------------------------------------
def test_the_held_out_check_needs_a_margin_in_noise_units():
    from ecds_lab.analysis.diagnosis.held_out import HELD_OUT_CHI2, held_out_gain
    from ecds_lab.analysis.noise import NoiseEstimate

    noise = NoiseEstimate(20.0, "test", 0)
    assert held_out_gain(115.2, 115.0, 700, noise) < HELD_OUT_CHI2  # 0.2 ppm of 115: no evidence
    assert held_out_gain(30.0, 21.0, 700, noise) > HELD_OUT_CHI2  # a residual brought to the noise
    correlated = NoiseEstimate(20.0, "test", 0, design_effect=4.0)
    assert held_out_gain(30.0, 21.0, 700, correlated) == pytest.approx(held_out_gain(30.0, 21.0, 700, noise) / 4)


# -- a group set aside as partial is not judged again and again -------------------------------------------------
def test_candidates_set_aside_as_partial_do_not_keep_the_search_going(monkeypatch, study_campaign):
    """The validation study's case 0 of seed 1 (the former's expansion and a drifting bridge gain, 15 kHz, coil and
    target heated): thermal_lag (and, while a false moisture claim came first, former_expansion too) explains part
    of the residual. Set aside, it stays in the ranking with its checks passed; when no other candidate passes the
    search must end, not re-judge the same partial group round after round (it went on for more than 15
    CPU-minutes). No moisture is claimed: its drying course is left open (docs/diagnosis.md, `identifiable`)."""
    rounds = []
    real_round = search._round

    def counted(*args, **kwargs):
        rounds.append(1)
        if len(rounds) > 20:
            raise AssertionError("the search went round more than 20 times")
        return real_round(*args, **kwargs)

    monkeypatch.setattr(search, "_round", counted)
    result = run_diagnosis(study_campaign(1, 0))
    assert result.partial and "thermal_lag" in result.partial[0], result.explanation
    assert not {"thermal_lag", "former_expansion", "parasitic_capacitance"} & set(result.claimed), result.explanation


def test_a_course_a_small_screen_leaves_open_is_judged_again_on_a_larger_one(campaign_with, monkeypatch,
                                                                           drying_judged_where_hottest):
    # 80 of the campaign's 904 readings leave the drying's rate where the coil is hottest open; 640 determine it, as
    # all of them do
    data = campaign_with("parasitic_capacitance")
    assert run_diagnosis(data).claimed[:1] == ["parasitic_capacitance"]
    screened = run_diagnosis(data, screen_rows=80)
    assert screened.claimed[:1] == ["parasitic_capacitance"], screened.explanation
    monkeypatch.setattr(search, "SCREEN_GROWTH", 1)
    kept_small = run_diagnosis(data, screen_rows=80)
    assert "parasitic_capacitance" in kept_small.undetermined and not kept_small.claimed, kept_small.explanation


def test_a_drying_faster_hot_than_cold_is_claimed_and_one_at_one_pace_is_not(campaign_with, study_campaign):
    """Drying is driven by heat (``Effect.in_time_alone``, ``checks.check_in_time``). The lab's moist former dries
    as the coil is heated: claimed, its fit beating the same drying in time alone. Validation study seed 2029 case
    149 (15 kHz, coil heated to 60 and 120 C; no moisture, the bridge's gain drifting by -126 ppm an hour, the
    former's expansion with a hysteresis, a lead screw): a drying from 22 C on at one pace took the drift and was
    claimed; in time alone it fits as well: not claimed, and the residual is outside the library, in time."""
    drying = run_diagnosis(campaign_with("parasitic_capacitance"))
    assert drying.claimed[:1] == ["parasitic_capacitance"], drying.explanation
    claimed = next(c for c in drying.steps[0].candidates if c.effect == "parasitic_capacitance")
    assert claimed.checks["needs_temperature"]
    drift = run_diagnosis(study_campaign(2029, 149))
    assert "parasitic_capacitance" not in drift.claimed, drift.explanation
    assert any(c.effect == "parasitic_capacitance" and c.checks.get("needs_temperature") is False
               for step in drift.steps for c in step.candidates), drift.explanation
    assert drift.verdict == "missing_effect" and "outside the library" in drift.explanation, drift.explanation
    assert "time_s" in [a.variable for a in drift.associations[:2]], drift.explanation
    assert ParasiticCapacitance.reveal_beside_drift in drift.suggested_measurements


def test_a_former_dry_before_the_hottest_hold_shows_its_drying_where_it_dried(study_campaign):
    """Validation study seed 2030 case 166 (the moist former, coil held at 40, 80 and 120 C, one sweep cold and one
    hot): the former is dry before the coil reaches 80 C, so its drying rate at 120 C is open (a factor 4.9e16) while
    the rate where it dried is known. The drying is judged there (``ParasiticCapacitance.drying_temperature``) and
    claimed; it was missed."""
    result = run_diagnosis(study_campaign(2030, 166))
    assert "parasitic_capacitance" in result.claimed, result.explanation
    drying = next(s for s in result.steps[1:] if s.effects[-1] == "parasitic_capacitance")
    effect = ParasiticCapacitance(SensorConfig())
    assert effect.drying_temperature(result.data, drying.fit.values) < 70.0 < float(result.data.t_coil_c.max())


def test_a_difference_between_the_directions_that_a_drift_leaves_as_well_is_no_backlash(field_lab, study_campaign):
    """A backlash is what the directions differ by (``Effect.drift_leaves_it``, ``checks.check_beyond_drift``). The
    faithful lab's 30 um of play, swept up and down once at 15 kHz in 3.4 minutes: claimed, beside a straight-line
    drift in time too. Validation study seed 2029 case 60 (500 Hz and 15 kHz, up and down, 7 minutes; no backlash, the
    bridge's gain drifting by 214 ppm an hour): 2.9 um of play was claimed (chi-square 59); beside a drift it gains
    nothing, and is not claimed."""
    lab = field_lab(slide={"backlash": {"enabled": True, "backlash_um": 30.0}})
    play = run_diagnosis(campaign.displacement_sweep(lab, campaign.PAPER_POSITIONS_MM, (15000.0,)))
    assert play.claimed == ["slide_backlash"], play.explanation
    assert next(c for c in play.steps[0].candidates if c.effect == "slide_backlash").checks["beyond_drift"]
    drift = run_diagnosis(study_campaign(2029, 60))
    assert "slide_backlash" not in drift.claimed, drift.explanation
    assert any(c.effect == "slide_backlash" and c.checks.get("beyond_drift") is False
               for step in drift.steps for c in step.candidates), drift.explanation
    assert SlideBacklash.reveal_beside_drift in drift.suggested_measurements  # the measurement that tells them apart


# -- the search's independent fits on two processes (forked.each) -----------------------------------------------
@pytest.mark.skipif(not forked.can_fork(), reason="this platform does not fork")
def test_a_diagnosis_with_its_fits_on_two_processes_is_the_one_made_in_one(campaign_with, monkeypatch):
    data = campaign_with("target_bending", "slide_backlash")
    alone = run_diagnosis(data, screen_rows=150)
    forked_at: set[str] = set()
    real_each = forked.each

    def each(work, items, shared=()):
        items = list(items)
        if len(items) > 1:
            forked_at.add(traceback.extract_stack()[-2].name)
        return real_each(work, items, shared)

    real_each_beside = forked.each_beside

    def each_beside(here, work, items, shared=()):
        if here is not None:  # a claim's refit beside its repolish's starts
            forked_at.add(traceback.extract_stack()[-2].name)
        return real_each_beside(here, work, items, shared)

    monkeypatch.setattr(forked, "each", each)
    monkeypatch.setattr(forked, "each_beside", each_beside)
    with forked.allowed(2):
        together = run_diagnosis(data, screen_rows=150)
    assert {"_round", "_refined", "cv_rmses", "_full_fit_beside_starts"} <= forked_at
    assert json.dumps(together.to_json(), sort_keys=True) == json.dumps(alone.to_json(), sort_keys=True)


@dataclasses.dataclass
class _Tried:
    """What a fake fit returns: its values and an RMS that falls with ``a`` and ``b``."""

    values: dict[str, float]
    model: object = None

    @property
    def rms_ppm(self) -> float:
        return 100.0 - 10.0 * self.values["a"] - self.values["b"]


class _StartsInA:
    alternative_starts = ({"a": 1.0}, {"a": 3.0})


class _StartsInB:
    alternative_starts = ({"b": 5.0}, {"b": 1.0})


class _Claimed:
    alternative_starts = ()


@pytest.fixture
def fake_repolish(monkeypatch):
    """Fits replaced by ``_Tried`` (its RMS falls with a and b); the starts they were made from, and a claimed model
    whose two effects before the claim have starts in a and in b."""
    tried: list[dict[str, float]] = []

    def fake_fit(model, data, *, start, **_):
        tried.append(dict(start))
        return _Tried(dict(start))

    monkeypatch.setattr(search, "fit_model", fake_fit)
    claimed = types.SimpleNamespace(model=types.SimpleNamespace(effects=[_StartsInA(), _StartsInB(), _Claimed()]))
    return tried, claimed


@pytest.mark.parametrize("workers", [1, 2])
def test_a_repolish_tries_the_starts_behind_a_winner_again_from_it(workers, fake_repolish):
    # one after another: a=1 wins (90 ppm), a=3 from it wins (70), b=5 from that wins (65), b=1 does not (69)
    tried, claimed = fake_repolish
    with forked.allowed(workers):
        best = search._best_start(_Tried({"a": 0.0, "b": 0.0}), "data", 2, claimed)
    assert best.values == {"a": 3.0, "b": 5.0}
    if workers == 1:  # tried here, so seen here: each start once, from the best so far
        assert tried == [{"a": 1.0, "b": 0.0}, {"a": 3.0, "b": 0.0}, {"a": 3.0, "b": 5.0}, {"a": 3.0, "b": 1.0}]


def test_a_repolish_whose_first_starts_were_tried_beside_the_refit_ends_where_it_would_have(fake_repolish):
    # the first starts, tried at once from the start while the claim was refitted (_full_fit_beside_starts), are
    # taken as they are; the starts behind the winner are then tried again from it, as without them
    tried, claimed = fake_repolish
    start = _Tried({"a": 0.0, "b": 0.0})
    first = [search._tried(claimed.model, "data", start, task) for task in search._restart_tasks(claimed.model, 2)]
    tried.clear()
    best = search._best_start(start, "data", 2, claimed, first)
    assert best.values == {"a": 3.0, "b": 5.0}
    assert {"a": 1.0, "b": 0.0} not in tried and tried[0] == {"a": 3.0, "b": 0.0}  # behind a=1's win, from it


class _StartsInC:
    """An effect with more starts than a repolish refits with the model free: they are scouted."""

    alternative_starts = ({"c": 1.0}, {"c": 4.0}, {"c": 2.0})

    @staticmethod
    def parameters():
        return [types.SimpleNamespace(name="c")]


@dataclasses.dataclass
class _TriedInC(_Tried):
    @property
    def rms_ppm(self) -> float:
        return 100.0 - self.values.get("c", 0.0)


@pytest.mark.parametrize("workers", [1, 2])
def test_a_repolish_scouts_an_effect_with_many_starts_and_refits_the_best_scouts_with_the_model_free(workers,
                                                                                                     monkeypatch):
    # c=1, 4 and 2 scouted with c alone free (the rest held where the best fit left it); the best two scouts (c=4,
    # c=2) refitted with the model free; c=4 wins, and c=2, behind it, is scouted again from it. The worst scout is
    # never refitted.
    made: list[tuple[dict[str, float], dict[str, float] | None]] = []
    budgets: set[tuple[bool, int | None]] = set()

    def fake_fit(model, data, *, start, fixed=None, budget=None, **_):
        made.append((dict(start), None if fixed is None else dict(fixed)))
        budgets.add((fixed is not None, budget))
        return _TriedInC(dict(start), model)

    monkeypatch.setattr(search, "fit_model", fake_fit)
    model = types.SimpleNamespace(effects=[_StartsInC(), _Claimed()])
    start = _TriedInC({"a": 0.5, "c": 0.0}, model)
    with forked.allowed(workers):
        best = search._best_start(start, "data", 1, start)
    assert best.values["c"] == 4.0
    if workers == 1:  # fitted here, so seen here
        scouts = [(fit_start, fixed) for fit_start, fixed in made if fixed is not None]
        assert [fit_start["c"] for fit_start, _ in scouts] == [1.0, 4.0, 2.0, 2.0]
        assert all(fixed == {"a": 0.5} for _, fixed in scouts)  # only the effect's own parameter free
        refitted = [fit_start["c"] for fit_start, fixed in made if fixed is None]
        assert 1.0 not in refitted and refitted[:2] == [4.0, 2.0]
        # a scout only ranks: it stops at its budget; a refit with the model free takes the solver's own
        assert budgets == {(True, search.REPOLISH_SCOUT_BUDGET), (False, None)}


def test_after_a_claim_the_next_round_weighs_its_candidates_against_the_claim_refitted_on_the_screen_beside_it(
        campaign_with, monkeypatch):
    """On a screened campaign a claim's refit on the screen and its held-out error there are made beside its refit
    on every reading (``_full_fit_beside_starts``): the next round takes both as they are, refitting no current
    model on the screen but the baseline (``_refitted_on``) and cross-validating none of them again."""
    data = campaign_with("target_bending", "slide_backlash")
    refitted: list[object] = []
    cross_validated: list[object] = []
    real_refitted_on, real_cv_rmses = search._refitted_on, search.cv_rmses

    def refitted_on(screen, fitted):
        refitted.append(fitted)
        return real_refitted_on(screen, fitted)

    def cv_rmses(screen, fits, folds):
        cross_validated.extend(fits)
        return real_cv_rmses(screen, fits, folds)

    monkeypatch.setattr(search, "_refitted_on", refitted_on)
    monkeypatch.setattr(search, "cv_rmses", cv_rmses)
    result = run_diagnosis(data, screen_rows=150)
    claims = result.steps[1:]
    assert claims and all(step.on_screen is not None for step in claims), result.explanation
    assert refitted == [result.steps[0].fit]
    assert not any(step.on_screen[1] is fit for step in claims for fit in cross_validated)
    assert all(step.candidates for step in claims)  # each was the current model of a round


# -- the robust start on a campaign larger than its reweighting's subsample ---------------------------------------
def test_a_robust_start_reweighted_on_a_subsample_excludes_the_glitches_the_one_on_every_reading_does(
        field_campaign, glitched, monkeypatch):
    data, rows = glitched(field_campaign(frequencies_hz=(15000.0,)), 5, -2500.0, seed=2)
    space = search._Space(search.SensorConfig(), search.library())
    sizes: list[int] = []
    real_fit = search.fit_model

    def fit_model(model, fitted, **options):
        if options.get("robust"):
            sizes.append(len(fitted))
        return real_fit(model, fitted, **options)

    monkeypatch.setattr(search, "fit_model", fit_model)
    every = search._robust_fit(data, [], space, len(data))
    assert sizes and set(sizes) == {len(data) - len(rows)}  # reweighted on every reading
    sizes.clear()
    screen_rows = len(data) // (3 * search.SCREEN_GROWTH)  # 144 of its 452 readings
    sampled = search._robust_fit(data, [], space, screen_rows)
    assert sizes and set(sizes) == {screen_rows * search.SCREEN_GROWTH}  # on a third of them
    assert [o.row for o in sampled[3]] == [o.row for o in every[3]] == rows
    # both end with the least-squares fit of every clean reading
    assert len(sampled[0]) == len(every[0]) and sampled[1].n == every[1].n == len(data) - len(rows)
    assert sampled[1].rms_ppm == pytest.approx(every[1].rms_ppm, rel=1e-4)


# -- candidates on a screened campaign weighed against the current model refitted there -----------------------
@pytest.mark.parametrize("screen_rows", [100, 200])
def test_on_a_screened_campaign_a_candidate_gains_only_what_its_effect_explains(campaign_with, screen_rows):
    # No effect in the lab: some candidate always has nothing to explain. Weighed against the solution on every
    # reading evaluated on the subsample, each gained what refitting the baseline there gains (the least of them
    # 7.3 and 8.6 chi-square on this campaign at 100 and 200 rows): evidence no effect had given.
    result = run_diagnosis(campaign_with(), screen_rows=screen_rows)
    gains = [candidate.chi2_gain for candidate in result.steps[0].candidates]
    assert len(gains) >= 5 and min(gains) < 1.0, gains
    assert result.verdict == "adequate" and not result.claimed, result.explanation


# -- a claim whose refit on every reading left its course open ---------------------------------------------------
@pytest.mark.parametrize("largest_screen", [search.LARGEST_SCREEN, 300])
def test_a_claim_refitted_into_a_poor_valley_is_refitted_from_its_own_starts(campaign_with, monkeypatch,
                                                                             largest_screen):
    # a drying refitted from the wrong side of its course (rate 1 /s, screening's budget) ends above the model
    # without it; scouted from its own starts (on every reading, or on a third of them: the largest screen) and
    # polished on every reading, it reaches the drying's valley
    data = campaign_with("parasitic_capacitance")
    monkeypatch.setattr(search, "LARGEST_SCREEN", largest_screen)
    space = search._Space(search.SensorConfig(), search.library())
    base = search.fit_model(space.model([]), data)
    model = space.model(["parasitic_capacitance"])
    stuck = search.fit_model(model, data, start={"drying_rate": 1.0}, multistart=False, screening=True)
    confirmed = search._confirmed("parasitic_capacitance", stuck, base, base.noise, data)
    assert not confirmed.passes and not search._course_open(confirmed)  # no evidence: no open course either
    sizes = _fitted_sizes(monkeypatch)
    refitted = search._from_own_starts(data, stuck)
    walked_first = [largest_screen] if len(data) > search.PRE_POLISH_GROWTH * largest_screen else []  # _polished
    assert sizes == [min(largest_screen, len(data))] * len(model.effects[-1].alternative_starts) + walked_first \
        + [len(data)]
    assert refitted.rms_ppm < 0.1 * stuck.rms_ppm
    assert search._confirmed("parasitic_capacitance", refitted, base, base.noise, data).passes
    if largest_screen >= len(data):
        # within 1 % of the best valley its starts reach (measured: 20.51 against 20.44 ppm; the drying's valleys lie
        # that close), and a refit in that valley is kept as it is
        best = search._from_own_starts(data, refitted)
        assert refitted.rms_ppm < 1.01 * best.rms_ppm
        assert search._from_own_starts(data, best) is best
    else:  # scouted on a third of the readings: a valley within 1 % of the best (measured: 20.49 against 20.44 ppm)
        monkeypatch.setattr(search, "LARGEST_SCREEN", len(data))
        assert refitted.rms_ppm < 1.01 * search._from_own_starts(data, stuck).rms_ppm


def _fitted_sizes(monkeypatch) -> list[int]:
    """The number of readings of every fit the search makes from now on, in order."""
    sizes: list[int] = []
    real_fit = search.fit_model

    def fit_model(model, data, **options):
        sizes.append(len(data))
        return real_fit(model, data, **options)

    monkeypatch.setattr(search, "fit_model", fit_model)
    return sizes


def test_on_a_campaign_many_times_the_largest_screen_a_polish_is_taken_there_first(campaign_with, monkeypatch):
    # 904 readings, more than PRE_POLISH_GROWTH times a largest screen of 100: a claim's solution on 60 readings is
    # polished on 100 first, then on every reading, and ends where polishing every reading at once ends
    data = campaign_with("parasitic_capacitance")
    monkeypatch.setattr(search, "LARGEST_SCREEN", 100)
    space = search._Space(search.SensorConfig(), search.library())
    model = space.model(["parasitic_capacitance"])
    start = search.fit_model(model, search.screened(data, 60)).values
    direct = search.fit_model(model, data, start=start, multistart=False, screening=True, polish=True)
    sizes = _fitted_sizes(monkeypatch)
    laddered = search._polished(model, data, start)
    assert sizes == [100, len(data)]
    assert laddered.rms_ppm == pytest.approx(direct.rms_ppm, rel=1e-3)
    # on fewer readings than that the polish is taken on every reading at once, as before
    sizes.clear()
    monkeypatch.setattr(search, "LARGEST_SCREEN", len(data) // search.PRE_POLISH_GROWTH + 1)
    assert search._polished(model, data, start).rms_ppm == direct.rms_ppm and sizes == [len(data)]


def test_a_course_a_subsample_leaves_open_is_told_from_a_claim_that_fails_otherwise(campaign_with,
                                                                                   drying_judged_where_hottest):
    # 80 of the drying campaign's 904 readings: clear evidence, a plausible size, the course open
    data = search.screened(campaign_with("parasitic_capacitance"), 80)
    space = search._Space(search.SensorConfig(), search.library())
    base = search.fit_model(space.model([]), data)
    fitted = search.fit_model(space.model(["parasitic_capacitance"]), data, start=base.values, multistart=False,
                              screening=True)
    confirmed = search._confirmed("parasitic_capacitance", fitted, base, base.noise, data)
    assert confirmed.checks["evidence"] and confirmed.checks["plausible"] and not confirmed.passes
    assert search._course_open(confirmed), confirmed.rejected


# -- modules a candidate needs are imported once, before any worker is forked ------------------------------------
def test_the_modules_a_candidate_declares_are_imported_before_the_first_round(field_lab, monkeypatch):
    """``Effect.modules_for_search``: imported in this process before the first round forks its workers (each of
    which would otherwise import them anew: scipy.signal, when the lead screw's periodogram used it, 0.65 s CPU a
    worker)."""
    from ecds_lab.model.effects import Effect, library

    class Declares(Effect):
        name = "declares_modules"
        modules_for_search = ("colorsys", "wave")

    imported: list[str] = []
    before_first_round: list[list[str]] = []
    real_import, real_round = search.importlib.import_module, search._round
    monkeypatch.setattr(search.importlib, "import_module", lambda name: imported.append(name) or real_import(name))
    monkeypatch.setattr(search, "_round", lambda *a, **k: before_first_round.append(list(imported)) or real_round(
        *a, **k))
    data = campaign.displacement_sweep(field_lab(), POSITIONS_MM, (15000.0,))
    run_diagnosis(data, candidates=["declares_modules"], registry=library().with_effects(Declares))
    assert before_first_round[0].count("colorsys") == 1 and before_first_round[0].count("wave") == 1
    assert imported.count("colorsys") == 1  # once, not per round


def test_a_claim_is_made_at_a_fit_that_passes_its_checks(study_campaign):
    """Validation study seed 2028, case 44 (15 kHz only, target and coil heated; a bending and a re-absorption): the
    repolish after tau_displacement's claim found a valley of the drying (onset 172 C) that took the model from 161
    to 45 ppm with tau_T(x)'s knot at 100 mm on its bound, and the claim was made there, checked only at 161 ppm. A
    claim's own parameters are off their bounds at the fit it is made with (``search._held``)."""
    result = run_diagnosis(study_campaign(2028, 44))
    for step in result.steps[1:]:
        effect = step.fit.model.effects[-1]
        keys = effect.key_names()
        assert not [name for name in keys if name in step.fit.free_names and at_bound(step.fit, name)], (
            step.effects, result.explanation)
