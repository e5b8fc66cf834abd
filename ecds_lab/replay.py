"""Re-run a recorded session: the run's own experiment, against its own transcripts.

``replay_run`` proves that today's drivers and runner still turn yesterday's bytes into
the same data; ``replay_station`` gives tests a Station whose instruments are recordings.
"""

from __future__ import annotations

import logging
import math
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ecds_lab.clock import Clock, SimulatedClock
from ecds_lab.config.experiment import EXPERIMENT_ADAPTER
from ecds_lab.config.loading import validate
from ecds_lab.config.station import InstrumentConfig, StationConfig
from ecds_lab.data.columns import COLUMN_NAMES, INDEX
from ecds_lab.errors import ReplayDivergence, RunFileError
from ecds_lab.runner.plan import build_plan
from ecds_lab.runner.runner import Runner
from ecds_lab.station import Station, open_station
from ecds_lab.storage.reader import RunFile, read_run
from ecds_lab.storage.run_file import RunWriter, metadata_for
from ecds_lab.transports.base import Transport
from ecds_lab.transports.replay import ReplayState, ReplayTransport

#: Columns not expected to reproduce: wall-clock time differs by nature.
_NOT_COMPARED = {"wall_time_s"}
_TIME_TOLERANCE_S = 0.5
#: How the replay of a killed run ends: where its transcripts end, with no instrument behind it.
ENDED_WITH_RECORDING = "stopped where the recording ends"


@dataclass
class ReplayResult:
    path: Path
    original_status: str
    replay_status: str
    original_points: int
    replayed_points: int
    differences: list[str] = field(default_factory=list)
    error: str = ""
    #: The first place the code left the recording (instrument, transcript position, expected, actual).
    divergence: str = ""
    #: The recorded run was interrupted (killed): only the part it measured was replayed.
    partial: bool = False

    @property
    def reproduced(self) -> bool:
        return not self.differences and self.original_points == self.replayed_points


def _recorded_yaml(run: RunFile, key: str, what: str) -> object:
    """A YAML document the run file carries (its experiment or station), parsed; RunFileError if unusable."""
    text = run.metadata.get(key, "")
    if not text.strip():
        raise RunFileError(f"{run.path}: no {what} configuration recorded ({key})")
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise RunFileError(f"{run.path}: the recorded {what} configuration ({key}) is not valid YAML: "
                           f"{getattr(exc, 'problem', exc)}") from exc


def replay_station(run: RunFile | str | Path) -> Station:
    """A Station for a recorded run: its drivers, with replay links serving the run's transcripts."""
    if not isinstance(run, RunFile):
        run = read_run(run)
    if run.metadata.get("resumed_from"):
        raise RunFileError(f"{run.path}: a resumed run holds two sessions; replay the original run file instead")
    if not run.transcripts:
        raise RunFileError(f"{run.path}: holds no transcripts to replay")
    station_yaml = run.metadata.get("station_yaml", "")
    config = validate(f"{run.path}:station_yaml", _recorded_yaml(run, "station_yaml", "station"), StationConfig)
    origin = min((events[0].clock_s for events in run.transcripts.values() if events), default=0.0)
    clock = SimulatedClock()
    state = ReplayState()  # one per station: the first divergence on any link stops them all

    def factory(role: str, instrument: InstrumentConfig, settings: dict[str, Any], station_clock: Clock) -> Transport:
        """The replay link of one role; ``station_clock`` is ``clock``, which replay links advance."""
        if role not in run.transcripts:
            raise RunFileError(f"{run.path}: no transcript for the {role}")
        return ReplayTransport(role, run.transcripts[role], clock=clock, clock_origin_s=origin,
                               write_termination=settings.get("write_termination", "\n"),
                               read_termination=settings.get("read_termination", "\n"),
                               timeout_s=settings.get("timeout_s", 2.0), state=state)

    return open_station(config, station_yaml, transport_factory=factory, clock=clock)


@contextmanager
def _runner_quiet() -> Iterator[None]:
    """Silence the runner's log while replaying: its warnings are about a lab (heater, slide) that is
    not there; the replay's own result says how the run ended and where it diverged."""
    runner_log = logging.getLogger("ecds_lab.runner")

    def drop_all(record: logging.LogRecord) -> bool:
        return False

    runner_log.addFilter(drop_all)
    try:
        yield
    finally:
        runner_log.removeFilter(drop_all)


def replay_run(path: str | Path) -> ReplayResult:
    """Execute the recorded experiment against the recorded traffic and compare the points."""
    original = read_run(path)
    experiment = validate(f"{path}:experiment_yaml", _recorded_yaml(original, "experiment_yaml", "experiment"),
                          EXPERIMENT_ADAPTER)
    plan = build_plan(experiment)
    station = replay_station(original)
    links = [t for t in station.transports.values() if isinstance(t, ReplayTransport)]
    status, error, replayed_points = "failed", "", np.empty((0, len(COLUMN_NAMES)))
    with tempfile.TemporaryDirectory() as folder, _runner_quiet():
        output = Path(folder) / "replay.h5"
        try:
            station.identify()
        except ReplayDivergence as exc:
            error = f"{type(exc).__name__}: {exc}"
        else:
            writer = RunWriter(output, metadata=metadata_for(original.metadata.get("experiment_yaml", ""),
                                                             station.yaml_text, plan.name, plan.kind),
                               transcripts={}, identities=station.identities)
            status, error = Runner(station, plan, writer, progress=False).run()
            writer.close(status, error)
            replayed_points = read_run(output, transcripts=False).points
        finally:
            station.close()
    result = ReplayResult(Path(path), original.status, status, len(original.points), len(replayed_points),
                          error=error)
    divergence = next((link.state.divergence for link in links if link.state.divergence is not None), None)
    closed = original.status in ("completed", "failed")
    if divergence is not None and _recording_ran_out(original, divergence):
        # a killed run's recording ends where it was killed: the replay reproduces the measured part. What
        # the runner did after that (make the lab safe) went to replay links whose recording had ended, not
        # to a heater: its "switch off by hand" is about no real instrument and is not the replay's ending.
        result.partial = True
        replayed_points = replayed_points[:len(original.points)]
        result.replayed_points = len(replayed_points)
        result.replay_status = ENDED_WITH_RECORDING
        result.error = ""
        divergence = None
    if divergence is not None:
        result.divergence = str(divergence)
        result.differences.append(f"diverged: {divergence}")
    elif closed:
        # A closed run's transcripts end where the run ended: a replay that left traffic unsent
        # (e.g. a driver that skips a command at the end) has not reproduced the session.
        result.differences += [link.remaining() for link in links if not link.finished]
    if closed and status != original.status:
        result.differences.append(f"status: recorded {original.status}, replayed {status}"
                                  + (f" ({error})" if error and divergence is None else ""))
    elif closed and divergence is None and error != original.metadata.get("error", ""):
        result.differences.append(f"how the run ends: recorded {original.metadata.get('error', '')!r}, "
                                  f"replayed {error!r}")
    result.differences += compare_points(original.points, replayed_points)
    return result


def _recording_ran_out(original: RunFile, divergence: ReplayDivergence) -> bool:
    """Whether the replay stopped only because an interrupted run's recording ends (it was killed)."""
    return original.status == "interrupted" and "expected the end of the recording" in str(divergence)


def compare_points(recorded: np.ndarray, replayed: np.ndarray, limit: int = 20) -> list[str]:
    """Where two points tables differ (row, column, both values); empty when they agree."""
    differences: list[str] = []
    if len(recorded) != len(replayed):
        differences.append(f"row count: recorded {len(recorded)}, replayed {len(replayed)}")
    for row in range(min(len(recorded), len(replayed))):
        for name in COLUMN_NAMES:
            if name in _NOT_COMPARED:
                continue
            a, b = recorded[row, INDEX[name]], replayed[row, INDEX[name]]
            tolerance = _TIME_TOLERANCE_S if name == "time_s" else 0.0
            same = (math.isnan(a) and math.isnan(b)) or a == b or abs(a - b) <= tolerance
            if not same:
                differences.append(f"row {row}, {name}: recorded {a!r}, replayed {b!r}")
                if len(differences) >= limit:
                    return differences
    return differences


def format_replay(result: ReplayResult) -> str:
    """Human summary for ``ecds-lab replay``."""
    head = (f"{result.path}: recorded {result.original_points} rows ({result.original_status}), "
            f"replayed {result.replayed_points} ({result.replay_status})")
    if result.partial:
        head += ("\nthe run was interrupted (its writer was killed): replayed the part it measured, up to where "
                 "its recording ends (the replay drives no instrument: nothing to switch off)")
    if result.reproduced:
        ending = f"; the run ends as recorded: {result.error}" if result.error else ""
        return head + "\nreproduced: every row equal" + ending
    lines = [head, "NOT reproduced:"] + [f"  {d}" for d in result.differences]
    if result.error and not result.divergence:
        lines.append(f"  replay stopped: {result.error}")
    return "\n".join(lines)
