"""The bridge settings a campaign's readings were taken with, as its run files record them (``experiment_yaml``).

The experiments plan-next proposes take their readings the same way: their separations are counted in the noise the
diagnosis measured on the campaign, which holds only for readings taken as the campaign's were. A campaign read at
the HM8118's 'medium' speed is noisier than one read at 'slow', its most accurate: a candidate read at the default
'slow' would be predicted with the medium noise, its separation under-counted by the square of the two noises' ratio
and its lab time that of another speed. A CSV, or a run file without its configuration, records no settings.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from ecds_lab.config.experiment import BridgeConfig
from ecds_lab.planning.recorded_runs import RecordedRun


def recorded_bridge(runs: Sequence[RecordedRun]) -> BridgeConfig | None:
    """The bridge settings most of the readings of the campaign's ``runs`` (``recorded_runs``) were taken with (the
    settings of the readings the campaign's noise is mostly estimated on); None when no run records them."""
    readings: Counter[str] = Counter()
    for recorded in runs:
        readings[recorded.experiment.bridge.model_dump_json()] += len(recorded.run.points)
    if not readings:
        return None
    return BridgeConfig.model_validate_json(readings.most_common(1)[0][0])
