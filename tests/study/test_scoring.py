"""The validation study's rules: how a diagnosis is judged against its case's truth, and how cases are drawn."""

from __future__ import annotations

import pytest

from ecds_lab.study.cases import Design, draw_case, draw_cases, truth_kinds
from ecds_lab.study.scoring import judge, rates

ONE_FREQUENCY_HEATED = Design((15000.0,), ("forward", "backward"), 16, False, (75.0,), (), 1)
TWO_FREQUENCIES_COLD = Design((500.0, 15000.0), ("forward",), 16, False, (), (), 1)


def case_with(truths, design, number=0):
    from ecds_lab.study.cases import Case

    return Case(number, 1, design, tuple(truths), {})


def report(verdict, claimed=(), alternatives=(), explanation=""):
    return {"verdict": verdict, "claimed": list(claimed), "alternatives": [list(g) for g in alternatives],
            "explanation": explanation}


def test_a_tie_between_the_truth_and_its_twin_is_right_at_one_frequency():
    j = judge(case_with(["bending"], ONE_FREQUENCY_HEATED),
              report("inconclusive", alternatives=[["target_bending", "target_tau_temperature"]]))
    assert j.right and j.found == ["bending"] and not j.wrong_claims


def test_claiming_an_effect_not_in_the_truth_is_a_confident_wrong_claim():
    j = judge(case_with(["backlash"], ONE_FREQUENCY_HEATED),
              report("missing_effect", ["slide_backlash", "thermal_lag"]))
    assert j.wrong_claims == ["thermal_lag"] and not j.right


def test_effects_true_of_the_faithful_lab_are_not_wrong_claims():
    j = judge(case_with([], TWO_FREQUENCIES_COLD), report("missing_effect", ["tau_displacement"]))
    assert j.null and not j.false_alarm and j.right


def test_outside_the_library_on_a_null_truth_is_a_false_alarm():
    j = judge(case_with(["glitches"], TWO_FREQUENCIES_COLD),
              report("missing_effect", explanation="the residual lies outside the library"))
    assert j.null and j.false_alarm and not j.right


def test_a_truth_the_design_cannot_reveal_is_not_counted():
    j = judge(case_with(["backlash"], TWO_FREQUENCIES_COLD), report("adequate"))  # one direction only
    assert j.revealable == [] and not j.null
    figures = rates([j])
    assert figures.judged_cases == 0 and figures.wrong_claim_cases == 0


def test_a_missed_revealable_truth_is_not_right():
    j = judge(case_with(["bending", "backlash"], ONE_FREQUENCY_HEATED), report("missing_effect", ["slide_backlash"]))
    assert j.found == ["backlash"] and j.missed == ["bending"] and not j.right


def test_rates_count_over_their_own_cases():
    judgements = [judge(case_with([], TWO_FREQUENCIES_COLD, i), report("adequate")) for i in range(3)]
    judgements.append(judge(case_with(["glitches"], TWO_FREQUENCIES_COLD, 3),
                            report("missing_effect", ["slide_backlash"])))
    figures = rates(judgements)
    assert (figures.null_cases, figures.false_alarms, figures.wrong_claim_cases) == (4, 1, 1)
    assert figures.false_alarm_rate == 0.25 and figures.right_rate == 0.75


def test_cases_are_drawn_reproducibly_and_independently_of_the_count():
    assert draw_cases(5, 7)[3] == draw_case(3, 7)
    assert draw_cases(5, 7) != draw_cases(5, 8)
    kinds = truth_kinds()
    for case in draw_cases(40, 7):
        assert len(case.truths) <= 3 and all(name in kinds for name in case.truths)


def test_a_truth_outside_the_library_is_found_only_where_it_lives():
    said = "the residual lies outside the library"
    inside = report("missing_effect", explanation=said)
    inside["associations"] = [{"variable": "x_mm"}, {"variable": "time_s"}]
    assert judge(case_with(["metal_object"], TWO_FREQUENCIES_COLD), inside).right
    elsewhere = dict(inside, associations=[{"variable": "t_coil_c"}, {"variable": "direction"}])
    assert judge(case_with(["metal_object"], TWO_FREQUENCIES_COLD), elsewhere).missed == ["metal_object"]
    claimed = report("missing_effect", ["slide_lead_screw"], explanation="")
    j = judge(case_with(["metal_object"], TWO_FREQUENCIES_COLD), claimed)
    assert j.wrong_claims == ["slide_lead_screw"] and not j.right


def test_noise_that_grows_with_the_heater_current_is_no_effect():
    j = judge(case_with(["heater_pickup"], ONE_FREQUENCY_HEATED),
              report("missing_effect", explanation="the residual lies outside the library"))
    assert j.null and j.false_alarm


def test_a_case_drawn_among_sensors_keeps_its_truth_and_design():
    """The sensor is drawn from a stream of its own: the default study (the paper's prototype alone) is unchanged, and
    a steel case is measured at 15 kHz whatever its design asked."""
    for number in range(20):
        paper, mixed = draw_case(number, 7), draw_case(number, 7, ("paper", "steel"))
        assert paper.sensor == "paper" and (mixed.truths, mixed.blocks, mixed.seed) == (paper.truths, paper.blocks,
                                                                                         paper.seed)
        if mixed.sensor == "steel":
            assert mixed.design.frequencies_hz == (15000.0,)
        else:
            assert mixed.design == paper.design
    assert {draw_case(n, 7, ("paper", "steel")).sensor for n in range(20)} == {"paper", "steel"}


def test_an_unknown_sensor_is_named():
    with pytest.raises(ValueError, match=r"unknown sensor.*granite.*known: paper"):
        draw_case(0, 7, ("paper", "granite"))


def test_a_steel_plates_magnetic_depth_is_true_of_steel_alone():
    from ecds_lab.study.cases import Case

    claimed = report("missing_effect", ["magnetic_depth"])
    on_steel = judge(Case(0, 1, ONE_FREQUENCY_HEATED, (), {}, "steel"), claimed)
    on_copper = judge(case_with([], ONE_FREQUENCY_HEATED), claimed)
    assert on_steel.right and not on_steel.wrong_claims
    assert on_copper.false_alarm and on_copper.wrong_claims == ["magnetic_depth"]


def test_a_metal_object_clears_the_small_coils_own_rim():
    """Drawn beside the paper's 75 mm rim, a bracket would sit 45 mm beyond a 30 mm coil's and show nothing; on the
    small coil it keeps the clearance drawn, from its own rim, and everything else of the case is the paper's."""
    bracketed = [n for n in range(60) if "metal_object" in draw_case(n, 7).truths]
    assert bracketed
    for number in bracketed:
        paper, small = draw_case(number, 7), draw_case(number, 7, ("small_coil",))
        on_paper = paper.blocks["imperfections"]["metal_object"]
        on_small = small.blocks["imperfections"]["metal_object"]
        clearance = on_paper["radial_mm"] - on_paper["radius_mm"] - 75.0
        assert 0.5 <= clearance <= 6.0
        assert on_small["radial_mm"] == pytest.approx(30.0 + on_paper["radius_mm"] + clearance)
        assert {k: v for k, v in on_small.items() if k != "radial_mm"} == {
            k: v for k, v in on_paper.items() if k != "radial_mm"}
        assert (small.truths, small.design, small.seed) == (paper.truths, paper.design, paper.seed)
