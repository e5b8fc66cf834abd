"""Plates of the other non-magnetic metals a sensor YAML may name, on the faithful lab (docs/simulated_lab.md,
"Plate": 5 mm of pure aluminium, 37.7 MS/m falling 0.43 %/K, or of brass, 15.5 MS/m falling 0.15 %/K): a
conductivity change is found with the metal's own temperature coefficient, not copper's."""

from __future__ import annotations

from functools import cache

import pytest

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import sensor_from
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.study.campaigns import QUIET_LAB
from ecds_lab.study.cases import merged

POSITIONS_MM = (20, 30, 40, 50, 60, 70, 80, 90, 100)
#: The metal's resistivity temperature coefficient a (docs/simulated_lab.md): sigma = sigma20 / (1 + a dT), so
#: d ln(sigma)/dT is -a at 20 C and -a/(1 + 55 a) at the 75 C set point; tau_T follows sigma.
COEFFICIENT_PER_K = {"aluminium": 0.0043, "brass": 0.0015}


@cache
def diagnosed(metal: str):
    """The diagnosis of a sweep at room temperature and one at 75 C, both directions, two readings a point, at
    15 kHz and then, the plate cooled again, at 500 Hz; only the plate's conductivity change switched on."""
    sensor = sensor_from(f"{metal} plate", {"target": metal})
    lab = SimulatedLab(LabConfig(physics="field", seed=3, sensor=sensor,
                                 **merged(QUIET_LAB, {"plate": {"conductivity": {"enabled": True}}})))
    runs = []
    for frequency_hz in (15000.0, 500.0):
        runs.append(campaign.displacement_sweep(lab, POSITIONS_MM, (frequency_hz,), repeats=2))
        runs.append(campaign.target_heating(lab, (75,), positions_mm=POSITIONS_MM, frequencies_hz=(frequency_hz,),
                                            repeats=2))
        lab.clock.sleep(campaign.settle_time_s(lab, campaign.TARGET_HEATER_OUTPUT))
    return run_diagnosis(Measurements.concatenate(runs), (), sensor)


@pytest.mark.parametrize("metal", sorted(COEFFICIENT_PER_K))
def test_a_conductivity_change_is_found_with_the_metals_own_coefficient(metal):
    result = diagnosed(metal)
    assert "target_tau_temperature" in result.claimed, result.explanation
    assert "target_bending" not in result.claimed, result.explanation
    assert result.final.rmse_ppm <= 1.5 * result.noise_ppm, result.explanation
    a = COEFFICIENT_PER_K[metal]
    tempco = result.final.fit.values["tau_tempco"]
    # between the coefficient's value at the hot set point and at 20 C, with a quarter's room either side
    assert -1.25 * a < tempco < -0.75 * a / (1 + 55 * a), tempco


def test_aluminiums_conductivity_falls_faster_with_temperature_than_brasss():
    """The two fits apart: aluminium's coefficient is 2.9 times brass's, and so is its fitted tempco nearly."""
    fitted = {metal: diagnosed(metal).final.fit.values["tau_tempco"]
              for metal in COEFFICIENT_PER_K}
    assert fitted["aluminium"] / fitted["brass"] > 2.0, fitted
