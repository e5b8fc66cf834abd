"""One run from files to run file: load and check the YAML, plan, open the station, run, close.

Everything that can be checked is checked before any instrument is opened. A resumed
run never modifies its predecessor: it writes a new file holding the old points and
transcripts followed by the missing points.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from ecds_lab.config.checks import check_experiment_fits_station
from ecds_lab.config.experiment import EXPERIMENT_ADAPTER, ExperimentConfig
from ecds_lab.config.loading import parse_yaml, read_text, validate
from ecds_lab.config.references import experiment_path as find_experiment
from ecds_lab.config.references import station_path as find_station
from ecds_lab.config.station import StationConfig
from ecds_lab.data.columns import INDEX
from ecds_lab.data.run_metadata import LINK_NOTES_ATTRIBUTE, SENSOR_ATTRIBUTE, sensor_attribute
from ecds_lab.errors import ConfigError, RunFileError
from ecds_lab.runner.context import RunContext
from ecds_lab.runner.plan import Plan, build_plan
from ecds_lab.runner.runner import Runner
from ecds_lab.runner.safe_state import ctrl_c_deferred, stop_signals_raise
from ecds_lab.runner.steps import CoolDown, WaitSteady
from ecds_lab.runner.temperature_hold import HOLD_UNITS
from ecds_lab.station import open_station
from ecds_lab.storage.reader import RunFile, read_run
from ecds_lab.storage.run_file import RunWriter, metadata_for
from ecds_lab.transports.base import Transport

log = logging.getLogger("ecds_lab.run")


@dataclass
class RunResult:
    path: Path
    status: str
    error: str
    points: int
    wall_s: float
    #: The signal that stopped the run (SIGINT for Ctrl-C, SIGTERM, SIGHUP), or None.
    stopped_by: int | None = None
    #: What the operator should know beyond the status: one line per link that discarded stale lines.
    notes: list[str] = field(default_factory=list)
    #: The heater regulation's lines: identified heater gains, holds out of tolerance (also in the run file).
    heater_notes: tuple[str, ...] = ()
    #: Readings the plan schedules one by one (its MeasurePoint steps)
    planned: int = 0
    #: Whether the plan waits on heaters, logging readings meanwhile
    logs_while_heating: bool = False
    #: Lab time the run took on the station's clock (s): the wall clock's on instruments, the simulated lab's own
    lab_s: float = 0.0

    def rows_are(self) -> str:
        """What the rows are, in the data contract's words (docs/data-contract.md, "Words")."""
        logged = "; readings logged while waiting on heaters come on top" if self.logs_while_heating else ""
        return f"one row per reading (the plan has {self.planned} planned readings{logged})"


def load_experiment(path: Path | str, text: str | None = None) -> ExperimentConfig:
    """Validate an experiment YAML (from its file or the text recorded in a run file)."""
    path = Path(path)
    return validate(str(path), parse_yaml(read_text(path) if text is None else text, str(path)), EXPERIMENT_ADAPTER)


def prepare(experiment_path: Path, station_path: Path | None) -> tuple[object, str, StationConfig, str, Plan]:
    """Load, validate and cross-check both files; build the plan. No instrument is touched.

    Either may be a path or a shipped name (``displacement_sweep``, ``simulated_lab``): see
    ``config/references.py``; no station means the shipped simulated lab.
    """
    experiment_path = find_experiment(experiment_path)
    experiment_text = read_text(experiment_path)
    experiment = load_experiment(experiment_path, experiment_text)
    station_path = find_station(station_path)
    station_text = read_text(station_path)
    station = validate(str(station_path), parse_yaml(station_text, str(station_path)), StationConfig)
    check_experiment_fits_station(experiment, station, str(experiment_path), str(station_path))
    return experiment, experiment_text, station, station_text, build_plan(experiment, station.thermal,
                                                                           station.regulation)


def default_output(experiment_path: Path, resume: Path | None) -> Path:
    if resume is not None:
        return resume.with_name(resume.stem + "-resumed.h5")
    stamp = time.strftime("%Y%m%d-%H%M%S")
    return Path(f"{Path(experiment_path).stem}-{stamp}.h5")


def run_experiment(experiment_path: Path, station_path: Path | None = None, output: Path | None = None, *,
                   resume: Path | None = None, overwrite: bool = False, progress: bool = True,
                   station_overrides: dict | None = None) -> RunResult:
    """Run an experiment into a run file; returns how it ended (the file is closed in every case).

    SIGTERM and SIGHUP are handled like Ctrl-C for the whole call (main thread only).
    """
    with stop_signals_raise():
        return _run_experiment(experiment_path, station_path, output, resume=resume, overwrite=overwrite,
                               progress=progress, station_overrides=station_overrides)


def _run_experiment(experiment_path: Path, station_path: Path | None, output: Path | None, *,
                    resume: Path | None, overwrite: bool, progress: bool,
                    station_overrides: dict | None) -> RunResult:
    experiment, experiment_text, station_config, station_text, plan = prepare(experiment_path, station_path)
    if station_overrides:
        station_config = station_config.model_copy(update=station_overrides)
    previous = read_run(resume) if resume is not None else None
    if previous is not None and previous.metadata.get("experiment_yaml", "").strip() != experiment_text.strip():
        raise ConfigError(f"{experiment_path}: differs from the experiment recorded in {resume}; "
                          "resume with the same experiment file")
    output = Path(output) if output is not None else default_output(experiment_path, resume)
    if resume is not None and output.resolve() == Path(resume).resolve():
        raise RunFileError(f"{output}: a resumed run goes to a new file and never modifies {resume}; "
                           "choose another -o")
    if output.exists() and not overwrite:
        raise RunFileError(f"{output} exists; choose another -o or pass --overwrite")
    if previous is not None:
        check_same_station(previous, station_config, None, station_path)
    started = time.monotonic()
    station = open_station(station_config, station_text)
    try:
        identities = station.identify()
        if previous is not None:
            check_same_station(previous, station_config, identities, station_path)
        writer = RunWriter(output, metadata=metadata_for(
            experiment_text, station_text, plan.name, plan.kind, getattr(experiment, "operator_note", ""),
            planned_points=str(len(plan.points)), resumed_from=str(resume or ""), sensor=station_config.sensor,
            slide_repeatability_um=station_config.slide.repeatability_um),
            transcripts={role: t.transcript for role, t in station.transports.items() if t.transcript},
            identities=identities, overwrite=overwrite)
        done: set[int] = set()
        offset = 0.0
        if previous is not None:
            done, offset = _carry_over(previous, writer)
        runner = Runner(station, plan, writer, done=done, time_offset_s=offset, progress=progress)
        began = station.clock.now()
        status, error = runner.run()
        lab_s = station.clock.now() - began
        notes = link_notes(station.transports.values())
        with ctrl_c_deferred():
            writer.close(status, error, {**({LINK_NOTES_ATTRIBUTE: json.dumps(notes)} if notes else {}),
                                         **regulation_attributes(runner.context)})
    finally:
        station.close()
    result = RunResult(output, status, error, writer.rows, time.monotonic() - started, runner.stopped_by, notes,
                       tuple(runner.context.notes) if runner.context is not None else (),
                       planned=len(plan.points), logs_while_heating=any(
                           isinstance(step, WaitSteady | CoolDown) and step.log is not None
                           and bool(step.log.frequencies_hz) for step in plan.steps), lab_s=lab_s)
    log.info("run %s: %d rows in %s (%.1f s)", status, result.points, output, result.wall_s)
    return result


def link_notes(transports: Iterable[Transport]) -> list[str]:
    """One line per link that discarded stale lines before its queries (each also logged as it happened)."""
    notes = [note for transport in transports if (note := transport.stale_note()) is not None]
    for note in notes:
        log.warning("%s", note)
    return notes


def regulation_attributes(context: RunContext | None) -> dict[str, str]:
    """The run file's record of the heater regulation (JSON attributes of /entry): each hold at a setpoint with
    its drift and verdict (``temperature_holds``, units in ``temperature_holds_units``) and each identified
    heater's plant and gains (``heater_identification``)."""
    if context is None or not (context.holds or context.identified):
        return {}
    return {"temperature_holds": json.dumps([hold.as_dict() for hold in context.holds]),
            "temperature_holds_units": json.dumps(HOLD_UNITS),
            "heater_identification": json.dumps(context.identified)}


def check_same_station(previous: RunFile, config: StationConfig, identities: dict[str, str] | None,
                       station_path: Path | None) -> None:
    """A resumed run continues on the station of the interrupted one: simulated or real alike, the same
    sensor and (once asked) the same instruments; otherwise ConfigError naming every difference."""
    given = f"station {station_path or 'simulated_lab'}"
    differences = []
    recorded = yaml.safe_load(previous.metadata.get("station_yaml", "") or "{}") or {}
    was_simulated = isinstance(recorded, dict) and recorded.get("simulated") is not None
    if was_simulated != (config.simulated is not None):
        differences.append(f"the interrupted run was on a {'simulated' if was_simulated else 'real'} station, "
                           f"{given} is {'simulated' if config.simulated is not None else 'real'}")
    recorded_sensor = previous.metadata.get(SENSOR_ATTRIBUTE, "")
    sensor = sensor_attribute(config.sensor) if config.sensor is not None else ""
    if recorded_sensor and sensor and json.loads(recorded_sensor) != json.loads(sensor):
        differences.append(f"sensor: recorded {json.loads(recorded_sensor).get('name')!r}, "
                           f"{given} has {json.loads(sensor).get('name')!r}")
    for role, identity in sorted((identities or {}).items()):
        before = previous.identities.get(role)
        if before is not None and before != identity:
            differences.append(f"{role}: recorded {before!r}, now {identity!r}")
    if differences:
        raise ConfigError(f"{previous.path}: cannot resume on another station ({'; '.join(differences)}); "
                          "resume with the station the run was started on (--station)")


def _carry_over(previous: RunFile, writer: RunWriter) -> tuple[set[int], float]:
    """Copy the predecessor's rows and transcripts; return its measured points and where time continues."""
    writer.append_rows(previous.points)
    for role, events in previous.transcripts.items():
        if role in writer.roles:
            writer.add_transcript_events(role, [(e.clock_s, e.wall_s, e.kind, e.text) for e in events])
    times = previous.points[:, INDEX["time_s"]]
    walls = previous.points[:, INDEX["wall_time_s"]]
    offset = float(np.nanmax(times)) + max(0.0, time.time() - float(np.nanmax(walls))) if len(times) else 0.0
    return previous.completed_points(), offset
