"""The diagnosis on positions other than the paper's: the faithful lab with nothing switched on, read at 500 Hz and
15 kHz nearer to the coil or further from it than 20-100 mm, or at a few positions only. The field solution's tau_T
changes with x wherever the coil is (docs/simulated_lab.md), so tau_displacement (and the winding's lag, on a heated
coil) is the truth; nothing lies outside the library."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import FAILING_RATIO, run_diagnosis
from ecds_lab.simulators import campaign

FAITHFUL = {"tau_displacement", "thermal_lag"}


@pytest.mark.parametrize("positions_mm", [np.linspace(11.0, 100.0, 10), np.linspace(11.0, 40.0, 9),
                                          np.linspace(20.0, 150.0, 14)], ids=["11-100 mm", "11-40 mm", "20-150 mm"])
def test_a_null_campaign_beyond_20_to_100_mm_is_no_alarm(field_config, positions_mm):
    """With the tau_T(x) spline ending at 20 and 100 mm (constant beyond), the 11-100 mm campaign was said to lie
    outside the library in x (opposite signs at the two frequencies at 10 and 20 mm: the screening's change with x
    nearer than the spline reached); its outer knots follow it to the noise. Over 11-40 mm, with the outer knot
    alone (straight between 10 and 20 mm), 24 ppm were left (1.3x the noise), outside the library; the 14 mm knot
    follows the change nearest the coil. The 20-150 mm campaign checks the far side (within the noise before too)."""
    data = campaign.paper_campaign(field_config(5), seed=5, positions_mm=positions_mm.tolist(),
                                   target_setpoints_c=(75, 130), coil_setpoints_c=(60.0, 120.0))
    result = run_diagnosis(data)
    assert "outside the library" not in result.explanation, result.explanation
    assert "tau_displacement" in result.claimed and set(result.claimed) <= FAITHFUL, result.explanation
    assert result.final.rmse_ppm <= FAILING_RATIO * result.noise_ppm, result.explanation


def test_a_short_campaign_at_two_frequencies_is_no_alarm(field_config):
    """Five positions, read at 500 Hz and 15 kHz: every knot of tau_T(x) was held below eight distinct positions,
    the faithful lab's tau(x) was left unmodelled, and the campaign was said to lie outside the library in x (162 ppm,
    8.5x the noise). Now the 20, 40 and 100 mm knots are free, every bend straight."""
    data = campaign.paper_campaign(field_config(5), seed=5, positions_mm=np.linspace(20.0, 100.0, 5).tolist(),
                                   target_setpoints_c=(75, 130), coil_setpoints_c=(60.0, 120.0))
    result = run_diagnosis(data)
    assert "lies outside the library" not in result.explanation, result.explanation
    assert "tau_displacement" in result.claimed and set(result.claimed) <= FAITHFUL, result.explanation
