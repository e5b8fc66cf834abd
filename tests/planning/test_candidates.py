"""The frequencies plan-next proposes (``candidates._other_frequencies``): the bridge's frequencies near 100 Hz to
50 kHz the campaign lacks, on a steel plate only those at which its screening depth's law holds."""

from __future__ import annotations

from functools import cache

import pytest

from ecds_lab import shipped
from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.station import StationConfig
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.library.magnetic_depth import lowest_frequency_hz
from ecds_lab.planning.candidates import candidate_settings
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.study.campaigns import QUIET_LAB


@cache
def proposed_hz(target: str) -> list[float]:
    """The frequencies of the target-hot candidates for a 15 kHz sweep of a plate of ``target``."""
    sensor = SensorConfig(target=target)
    lab = SimulatedLab(LabConfig(physics="field", seed=1, sensor=sensor, **QUIET_LAB))
    data = campaign.displacement_sweep(lab, [20.0, 40.0, 60.0, 80.0], (15000.0,))
    station = load_yaml_model(shipped.station("simulated_lab.yaml"), StationConfig)
    return sorted(f for name, _, settings in candidate_settings(data, station, sensor) if name.startswith("target_hot")
                  for f in settings["sweep"]["frequencies_hz"])


def test_a_copper_plate_at_15_khz_is_offered_the_low_frequencies():
    assert {500.0, 5000.0, 50000.0} <= set(proposed_hz("copper"))


def test_a_steel_plate_is_offered_no_frequency_below_its_laws_range():
    lowest = lowest_frequency_hz(SensorConfig(target="steel"))
    assert 1e4 < lowest < 15000.0
    assert proposed_hz("steel") == [50000.0]


@pytest.mark.parametrize(("inner_m", "outer_m"), [(0.055, 0.075), (0.02, 0.03)])
def test_the_law_holds_where_the_textbook_steels_depth_is_a_small_share_of_the_winding(inner_m, outer_m):
    """D = 9.2 mm at 15 kHz falls as f^-1/2: at the lowest frequency it is 0.15 of the mean radius, so a small coil
    needs a higher frequency than the paper's."""
    sensor = SensorConfig(target="steel", coil={"inner_radius_m": inner_m, "outer_radius_m": outer_m})
    lowest = lowest_frequency_hz(sensor)
    depth_there_m = 9.2e-3 * (15000.0 / lowest) ** 0.5
    assert depth_there_m == pytest.approx(0.15 * 0.5 * (inner_m + outer_m))
    assert lowest_frequency_hz(SensorConfig(target="copper")) == 0.0
