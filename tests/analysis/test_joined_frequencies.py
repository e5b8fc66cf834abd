"""A campaign joined from runs at 15 kHz and at 500 Hz on the faithful lab (issue 26, starting campaign (b)):
a 5 mm copper plate screens like a perfect conductor Re{coth(gamma d)/gamma} behind its face (docs/physics.md,
"Two frequencies on a thick plate"), about a millimetre deeper at 500 Hz than at 15 kHz, which the one
calibration offset p1 both frequencies share cannot follow."""

from __future__ import annotations

import pytest

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.data.measurements import Measurements
from ecds_lab.simulators import campaign

POSITIONS_MM = (20, 30, 40, 50, 60, 70, 80, 90, 100)


def _run(lab, frequency_hz: float) -> Measurements:
    """A room-temperature sweep and one at 75 C, both directions, two readings a point: starting campaign (b)."""
    room = campaign.displacement_sweep(lab, POSITIONS_MM, (frequency_hz,), repeats=2)
    hot = campaign.target_heating(lab, (75,), positions_mm=POSITIONS_MM, frequencies_hz=(frequency_hz,), repeats=2)
    return Measurements.concatenate([room, hot])


@pytest.mark.xfail(strict=True, reason=(
    "one tau_T and one calibration for both frequencies: the baseline leaves 225 ppm (11.5x the 19.5 ppm noise) and "
    "nothing is claimed. The skin recession per frequency in the baseline (plate thickness fitted) brings it to "
    "70 ppm and 25 ppm with target_tau_temperature (claimed, -0.0050/K, 5.6 mm; tried on branch joint-recession, "
    "not kept): it broke four faithful-lab tests (a 1 mm plate, the three-part truth, the former's expansion, exact vs "
    "finite-difference standard errors) because a first-order recession misdescribes plates comparable to the 500 "
    "Hz skin depth and leaves the second-order term, -(Im c)^2/2 d2k^2/dx2, as structure"))
def test_a_joined_500_hz_and_15_khz_campaign_fits_and_claims_the_conductivity_change(field_lab):
    lab = field_lab(plate={"conductivity": {"enabled": True}})
    data = Measurements.concatenate([_run(lab, 15000.0), _run(lab, 500.0)])
    result = run_diagnosis(data)
    assert "target_tau_temperature" in result.claimed, result.explanation
    assert "target_bending" not in result.claimed, result.explanation
    # one tau_T and one calibration for both frequencies left ~10x the noise (chi-square ~5000 over ~150 readings)
    assert result.final.rmse_ppm <= 3.0 * result.noise_ppm, result.explanation
    # copper's conductivity falls ~0.39 %/K, its tau_T with it
    assert -0.006 < result.final.fit.values["tau_tempco"] < -0.002
