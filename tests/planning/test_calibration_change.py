"""The robustness of plan-next's separations to what the rival models leave out: a smooth change of the new run's
calibration (``planning.calibration_change``). A separation that is only a slow drift over the run, which any lab
drift could fake, must not count as deciding, however large its Delta chi-square and whichever reading is left out.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.config.loading import parse_yaml, read_text, validate
from ecds_lab.config.station import StationConfig
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import library
from ecds_lab.planning.calibration_change import calibration_change_columns
from ecds_lab.planning.candidates import station_candidates
from ecds_lab.planning.choice import rivals_of
from ecds_lab.planning.conditions import planned_readings, room_temperature_c
from ecds_lab.planning.discrimination import DECISIVE_CHI2, decisive, separation
from ecds_lab.planning.questions import open_questions
from ecds_lab.planning.rivals import Rival
from ecds_lab.storage.data_file import open_campaign


@dataclasses.dataclass
class Drifting(Rival):
    """A rival whose readings drift over a run: ``ppm_per_run`` from its first reading to its last."""

    ppm_per_run: float = 0.0

    def predict(self, data: Measurements) -> np.ndarray:
        span = max(float(np.ptp(data.time_s)), 1.0)
        return super().predict(data) * (1.0 + 1e-6 * self.ppm_per_run * (data.time_s - data.time_s.min()) / span)


def test_a_separation_that_a_drift_of_the_run_fakes_does_not_decide(started):
    station, run = started("a")
    opened = open_campaign([run])
    result = run_diagnosis(opened.data, (), opened.sensor)
    config = validate(str(station), parse_yaml(read_text(station), str(station)), StationConfig)
    rival = rivals_of(open_questions(result, library())[0], result, library())[0]
    repeat = next(c for c in station_candidates(result.data, config)[0] if c.name == "repeat")
    planned = planned_readings(repeat.plan, config, room_temperature_c(result.data), result.data)
    # the same model, its readings drifting by 20 noise figures over the repeated sweep: nothing but a drift
    truth = Drifting(**{f.name: getattr(rival, f.name) for f in dataclasses.fields(Rival)},
                     ppm_per_run=20.0 * result.noise.ppm)
    found = separation(truth, rival, result.data, planned, result.noise)
    assert found.delta_chi2 >= 4 * DECISIVE_CHI2 and found.robust_chi2 >= DECISIVE_CHI2  # the old guarantee: decides
    assert found.calibration_chi2 < 0.2 * DECISIVE_CHI2  # a drift of the run absorbs it
    assert decisive([found]) < DECISIVE_CHI2


def test_the_calibration_change_of_a_sweep_is_an_offset_a_drift_and_a_curve_in_distance_per_frequency(started):
    station, run = started("a")
    opened = open_campaign([run])
    config = validate(str(station), parse_yaml(read_text(station), str(station)), StationConfig)
    candidates = {c.name: c for c in station_candidates(opened.data, config)[0]}
    sweep = planned_readings(candidates["repeat"].plan, config, 22.0, opened.data)
    in_air = planned_readings(candidates["coil_ramps"].plan, config, 22.0, opened.data)
    assert calibration_change_columns(sweep).shape == (len(sweep), 4 * len(np.unique(sweep.freq_hz)))
    assert calibration_change_columns(in_air).shape == (len(in_air), 2 * len(np.unique(in_air.freq_hz)))
    assert np.all(np.isfinite(calibration_change_columns(in_air)))
