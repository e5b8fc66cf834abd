"""The readings plan-next predicts a candidate will take are the readings its run records (issue 26): the predicted
Delta chi-square is counted on them, so a reading the run does not keep (logged after homing, before the slide's
first move: no distance) or a direction it does not record would change the prediction, not the measurement.

Every candidate plan-next can write, on a slide that approaches from one side (a) and one that approaches directly
(c), is run on the faithful lab and its run file compared with ``planned_rows`` / ``planned_readings``: every planned
point in order (step, commanded distance, frequency, direction); every step that logs while a heater waits, with
the distances, frequencies and directions it logs at. How many readings a wait logs is the plan's estimate of the
wait (the station's thermal figures): the lab's own response decides it, and it is only compared (docs/planning.md).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml

from ecds_lab.config.loading import parse_yaml, read_text, validate
from ecds_lab.config.station import StationConfig
from ecds_lab.data.columns import LOGGED_POINT, PLANNED_POINT
from ecds_lab.planning.candidates import station_candidates
from ecds_lab.planning.conditions import planned_readings, planned_rows, room_temperature_c
from ecds_lab.runner.session import run_experiment
from ecds_lab.storage.data_file import open_campaign
from ecds_lab.storage.reader import located, read_measurements, read_run

Row = tuple[int, float, float, int]  # step, commanded distance (mm), frequency (Hz), direction


def _recorded(path: Path) -> dict[int, list[Row]]:
    """The run file's rows with a reading and a distance, by kind: (step, x, f, direction) in order."""
    run = read_run(path, transcripts=False)
    keep = np.isfinite(run.column("ls_h")) & located(run.column("x_commanded_mm"))
    columns = [run.column(name)[keep] for name in ("kind", "step", "x_commanded_mm", "freq_hz", "direction")]
    out: dict[int, list[Row]] = {PLANNED_POINT: [], LOGGED_POINT: []}
    for kind, step, x, f, d in zip(*columns, strict=True):
        out[int(kind)].append((int(step), round(float(x), 3), float(f), int(d)))
    return out


@pytest.mark.parametrize("case", ["a", "c"])
def test_the_planned_readings_are_the_readings_the_run_records(case, started, tmp_path):
    station, run = started(case)
    config = validate(str(station), parse_yaml(read_text(station), str(station)), StationConfig)
    data = open_campaign([run]).data
    room = room_temperature_c(data)
    candidates, _ = station_candidates(data, config)
    kinds = set()
    for candidate in candidates:
        kinds.add(candidate.experiment.kind)
        path = tmp_path / f"{candidate.name}.yaml"
        path.write_text(yaml.safe_dump(candidate.settings(), sort_keys=False), encoding="utf-8")
        result = run_experiment(path, station, tmp_path / f"{candidate.name}.h5", progress=False)
        assert result.status == "completed", result.error
        recorded = _recorded(tmp_path / f"{candidate.name}.h5")
        rows = [r for r in planned_rows(candidate.plan, config, room) if located(np.array([r.x_commanded_mm]))[0]]
        planned = {kind: [(r.step, round(r.x_commanded_mm, 3), r.freq_hz, r.direction) for r in rows
                          if r.kind == kind] for kind in (PLANNED_POINT, LOGGED_POINT)}
        assert planned[PLANNED_POINT] == recorded[PLANNED_POINT], candidate.name
        assert ({(s, x, f, d) for s, x, f, d in planned[LOGGED_POINT]}
                == {(s, x, f, d) for s, x, f, d in recorded[LOGGED_POINT]}), candidate.name
        assert len(planned_readings(candidate.plan, config, room, data)) == len(rows), candidate.name
        if not planned[LOGGED_POINT]:  # nothing waits on a heater: every reading is planned, the count exact
            assert len(read_measurements(tmp_path / f"{candidate.name}.h5")) == len(rows), candidate.name
        else:  # the steps that log are the same; how many each logs is the estimate's
            assert (Counter(s for s, *_ in planned[LOGGED_POINT]).keys()
                    == Counter(s for s, *_ in recorded[LOGGED_POINT]).keys()), candidate.name
    assert {"target_heating", "displacement_sweep", "coil_heating"} <= kinds
