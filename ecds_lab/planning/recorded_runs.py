"""The campaign's run files with the experiment each recorded (``experiment_yaml``), read once for all that planning
learns from them: the heater waits (``recorded_waits``) and the bridge settings (``recorded_bridge``). A CSV, a
missing file, or a run file without a configuration this ecds-lab can read records nothing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import yaml

from ecds_lab.config.experiment import EXPERIMENT_ADAPTER, ExperimentConfig
from ecds_lab.data.files import file_kind
from ecds_lab.errors import EcdsLabError
from ecds_lab.storage.reader import RunFile, read_run


@dataclass(frozen=True)
class RecordedRun:
    """A run file (without its transcripts) and the experiment it ran."""

    run: RunFile
    experiment: ExperimentConfig


def recorded_runs(paths: Sequence[str | Path]) -> list[RecordedRun]:
    """Every run file among ``paths`` that records its experiment, in order."""
    out = []
    for path in paths:
        try:
            if file_kind(Path(path)) == "csv":
                continue
            run = read_run(path, transcripts=False)
            experiment = EXPERIMENT_ADAPTER.validate_python(yaml.safe_load(run.metadata.get("experiment_yaml", "")))
        except (EcdsLabError, ValueError, yaml.YAMLError):
            continue  # a file without its configuration, or one this ecds-lab cannot read the experiment of
        out.append(RecordedRun(run, experiment))
    return out
