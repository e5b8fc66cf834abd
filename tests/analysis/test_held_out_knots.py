"""tau(x) over nine positions 10 mm apart (docs/diagnosis.md, ``held_out``): the one position between its 20 and 40 mm
knots, held out, would leave the knot at 28 mm free; the fold's fit holds the spline straight there, and tau(x) is
judged on interpolation."""

from __future__ import annotations

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.study.campaigns import measure, sensor_of
from ecds_lab.study.cases import draw_case


def test_tau_x_over_nine_positions_is_claimed_on_its_held_out_error():
    """Validation study seed 2033 case 188: 500 Hz and 15 kHz, nine positions up and down, nothing heated; tau_T(x) is
    true of the faithful lab at two frequencies. It took 140 to 33 ppm, but held out it was 765 against 255 ppm, and
    nothing was claimed. (Its 20 um backlash, swept up and down once, stays short of a claim's evidence beside it.)"""
    case = draw_case(188, 2033)
    assert case.design.positions == 9 and case.design.two_frequencies
    result = run_diagnosis(measure(case), (), sensor_of(case))
    assert "tau_displacement" in result.claimed, result.explanation
    claimed = next(c for c in result.steps[0].candidates if c.effect == "tau_displacement")
    assert claimed.cv_rmse_ppm < claimed.base_cv_rmse_ppm, (claimed.cv_rmse_ppm, claimed.base_cv_rmse_ppm)
