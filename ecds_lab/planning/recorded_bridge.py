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
from pathlib import Path

import yaml

from ecds_lab.config.experiment import EXPERIMENT_ADAPTER, BridgeConfig
from ecds_lab.data.files import file_kind
from ecds_lab.errors import EcdsLabError
from ecds_lab.storage.reader import read_run


def recorded_bridge(paths: Sequence[str | Path]) -> BridgeConfig | None:
    """The bridge settings most of the readings of the run files among ``paths`` were taken with (the settings of
    the readings the campaign's noise is mostly estimated on); None when no file records them."""
    readings: Counter[str] = Counter()
    for path in paths:
        try:
            if file_kind(Path(path)) == "csv":
                continue
            run = read_run(path, transcripts=False)
            experiment = EXPERIMENT_ADAPTER.validate_python(yaml.safe_load(run.metadata.get("experiment_yaml", "")))
        except (EcdsLabError, ValueError, yaml.YAMLError):
            continue  # a file without its configuration, or one this ecds-lab cannot read the experiment of
        readings[experiment.bridge.model_dump_json()] += len(run.points)
    if not readings:
        return None
    return BridgeConfig.model_validate_json(readings.most_common(1)[0][0])
