"""A library effect that takes the final residual to the noise, refused only because a slow drift in time between the
sweeps explains it as well (docs/diagnosis.md, "Alike a drift"): the residual is that effect or a drift, not shown to
lie outside the library."""

from __future__ import annotations

from functools import cache

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.model.effects import library
from ecds_lab.planning.questions import open_questions
from ecds_lab.study.campaigns import measure, sensor_of
from ecds_lab.study.cases import draw_case


@cache
def _backlash_once_up_and_down():
    """Validation study seed 2037 case 30 on the small coil: 15 kHz, 16 positions up and down once, no repeats; a true
    backlash and glitches. The residual lives in the direction; a backlash takes it to the noise, but beside a
    straight line in time it gains less than a claim needs."""
    case = draw_case(30, 2037, ("small_coil",))
    assert case.truths == ("backlash", "glitches") and case.design.both_directions
    return run_diagnosis(measure(case), (), sensor_of(case))


def test_a_backlash_a_drift_explains_as_well_is_neither_claimed_nor_called_outside_the_library():
    result = _backlash_once_up_and_down()
    assert result.verdict == "inconclusive" and not result.claimed, result.explanation
    assert result.drift_alike == ["slide_backlash"] and result.to_json()["drift_alike"] == ["slide_backlash"]
    assert result.associations[0].variable == "direction", result.explanation
    assert "it lies outside the library" not in result.explanation
    assert "slide_backlash or such a drift" in result.explanation
    said, tells = result.explanation.index("or such a drift"), result.explanation.index("To tell them apart: sweep up")
    assert said < tells  # the measurement follows what it tells apart
    assert any("up and down twice over" in s for s in result.suggested_measurements), result.suggested_measurements


def test_plan_next_asks_which_it_is_and_does_not_report_it_outside_the_library():
    questions = open_questions(_backlash_once_up_and_down(), library())
    kinds = [q.kind for q in questions]
    assert "drift_alike" in kinds and "outside_library" not in kinds, kinds
    asked = next(q for q in questions if q.kind == "drift_alike")
    assert asked.effects == ("slide_backlash",) and "up and down twice over" in asked.text
