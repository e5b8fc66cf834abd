"""At one frequency a smooth calibration curve in x takes any smooth change of the coupling with distance: a final
residual whose structure that curve takes is the calibration's form (Eq. (5) not following the sensor's coupling, or
an effect the calibration absorbs there), not physics shown to lie outside the library (docs/diagnosis.md, "The
calibration's form"). A bump narrower than the curve can follow stays outside it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ecds_lab import shipped
from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.config.loading import parse_yaml, read_text, validate
from ecds_lab.config.station import StationConfig
from ecds_lab.model.effects import library
from ecds_lab.planning.choice import plan_next
from ecds_lab.planning.questions import open_questions
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.study.campaigns import QUIET_LAB, measure, sensor_of
from ecds_lab.study.cases import draw_case, merged


def assert_the_calibrations_form(result) -> None:
    assert result.verdict == "inconclusive" and not result.claimed, result.explanation
    assert result.calibration_form is not None and "outside the library" not in result.explanation
    assert "calibration's form" in result.explanation and "x_mm" in result.explanation


@pytest.fixture(scope="module")
def steel_at_one_frequency():
    """Validation study seed 2031 case 2 drawn on steel: nothing switched on, the target heated once, nine positions
    at 15 kHz."""
    case = draw_case(2, 2031, ("steel",))
    return run_diagnosis(measure(case), (), sensor_of(case))


def test_a_steel_plate_over_nine_positions_at_one_frequency_is_the_calibrations_form(steel_at_one_frequency):
    """The ECM leaves 80 ppm (4.3x the noise) in x, and magnetic_depth's curvature is absorbed by the same curve
    there (untestable): it was a false alarm, 'outside the library'."""
    assert "magnetic_depth" in steel_at_one_frequency.untestable
    assert_the_calibrations_form(steel_at_one_frequency)


def test_plan_next_asks_a_second_frequency_where_the_calibrations_form_takes_the_residual(steel_at_one_frequency):
    """The calibration's form is not a residual outside the library (no experiment could change that), but a
    question a second frequency answers: plan-next asks it and designs for the effect the calibration absorbs."""
    questions = open_questions(steel_at_one_frequency, library())
    kinds = {q.kind: q for q in questions}
    assert "outside_library" not in kinds and "magnetic_depth" in kinds["calibration_form"].effects, questions
    station = shipped.station()
    plan = plan_next(steel_at_one_frequency, library(),
                     validate(str(station), parse_yaml(read_text(station), str(station)), StationConfig))
    assert plan.chosen is not None, plan.why
    assert set(plan.chosen.candidate.settings()["sweep"]["frequencies_hz"]) - {15000.0}, plan.chosen.candidate.what


def test_a_small_coil_at_500_hz_alone_is_the_calibrations_form():
    """The small coil's coupling over 20-100 mm (1-5 radii) at 500 Hz, where the field solution's screening changes
    with x as no single loop's: Eq. (5) leaves +15 ppm over the range (1.1x each reading's noise, 9 sd in x); it
    was a false alarm on a campaign with nothing switched on (validation study seed 2026 case 29's design at
    500 Hz; its case 26 is still one: there the curve takes three quarters of the structure only, as of a bump)."""
    case = draw_case(29, 2026, ("small_coil",))
    case = dataclasses.replace(case, design=dataclasses.replace(case.design, frequencies_hz=(500.0,)))
    assert case.truths == ()
    result = run_diagnosis(measure(case), (), sensor_of(case))
    assert_the_calibrations_form(result)


@pytest.mark.parametrize("step_mm", [4.0, 2.0])
def test_a_metal_objects_bump_at_one_frequency_stays_outside_the_library(step_mm):
    """The bracket's bump (15 mm full width) read every 4 or 2 mm at 15 kHz alone: narrower than the smooth
    curve follows, it is still outside the library and lives in x."""
    config = LabConfig(physics="field", seed=5, **merged(QUIET_LAB, {"imperfections": {"metal_object": {
        "enabled": True, "radius_mm": 4.0, "radial_mm": 80.0}}}))
    data = campaign.displacement_sweep(SimulatedLab(config), np.arange(20.0, 100.01, step_mm).tolist(), (15000.0,),
                                       repeats=2, air_repeats=10)
    result = run_diagnosis(data)
    assert result.verdict == "missing_effect" and not result.claimed, result.explanation
    assert result.calibration_form is None and "outside the library" in result.explanation
    assert result.associations[0].variable == "x_mm"


def test_a_bump_the_curve_follows_in_part_stays_outside_the_library():
    """Validation study seed 2026 case 183: a metal object alone, 16 positions at 15 kHz (three readings in its
    bump): the curve takes half of the structure (201 -> 95 noise variances), more than FORM_LEAVES leaves, so the
    bump is still outside the library, in x."""
    result = run_diagnosis(measure(draw_case(183, 2026)))
    assert result.verdict == "missing_effect" and not result.claimed, result.explanation
    assert result.calibration_form is None and "outside the library" in result.explanation
    assert result.associations[0].variable == "x_mm"


def test_beside_a_claimed_effect_what_is_left_is_inconclusive_not_the_diagnosis():
    """Validation study seed 2030 case 45 (a bending and a metal object, 15 kHz alone): the bending is claimed
    (verdict ``missing_effect``) and the calibration's form takes what is left. The text said "so the diagnosis is
    inconclusive" under the verdict missing_effect; it says what is inconclusive: what is left beyond the claim."""
    result = run_diagnosis(measure(draw_case(45, 2030)))
    assert result.verdict == "missing_effect" and result.claimed == ["target_bending"], result.explanation
    assert result.calibration_form is not None, result.explanation
    assert "the diagnosis is inconclusive" not in result.explanation
    assert "so what is left beyond target_bending is inconclusive" in result.explanation
