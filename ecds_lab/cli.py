"""The ``ecds-lab`` command line (DESIGN.md): run, demo, fit, diagnose, report, replay, export, watch, list."""

from __future__ import annotations

import argparse
import json
import logging
import os
import signal
import sys
import traceback
from collections.abc import Callable, Sequence, Sized
from pathlib import Path
from typing import TYPE_CHECKING

from ecds_lab import __version__, forked
from ecds_lab.errors import EcdsLabError, InvalidSettingError

if TYPE_CHECKING:
    from ecds_lab.model.effects import EffectRegistry
    from ecds_lab.storage.data_file import Campaign

log = logging.getLogger("ecds_lab")


def _cmd_run(args: argparse.Namespace) -> int:
    from ecds_lab.runner.session import prepare, run_experiment

    if args.dry_run:
        *_, plan = prepare(args.experiment, args.station)
        print(plan.describe())
        return 0
    if args.watch:
        args.output = args.output or _default_output(args)
        _start_watch(args.output)
    result = run_experiment(args.experiment, args.station, args.output, resume=args.resume,
                            overwrite=args.overwrite, progress=not args.quiet)
    print(f"{result.status}: {result.points} rows in {result.path} ({result.wall_s:.1f} s); {result.rows_are()}")
    if result.error:
        print(f"error: {result.error}", file=sys.stderr)
    for note in result.heater_notes:
        print(note, file=sys.stderr if note.startswith("WARNING") else sys.stdout)
    for note in result.notes:
        print(f"note: {note}", file=sys.stderr)
    if args.watch:
        _keep_watching()
    return _run_exit_code(result.status, result.stopped_by)


def _run_exit_code(status: str, stopped_by: int | None) -> int:
    """0 completed; 128 + signal when a signal stopped the run (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP); else 1."""
    from ecds_lab.runner.safe_state import exit_code

    if status == "completed":
        return 0
    if stopped_by is not None and status == "aborted":
        return exit_code(stopped_by)
    return 1


def _keep_watching() -> None:
    """After ``run --watch``: the live page stays up, showing how the run ended, until Ctrl-C."""
    import time

    print("the live view stays up (Ctrl-C to stop)", flush=True)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass


def _default_output(args: argparse.Namespace) -> Path:
    from ecds_lab.runner.session import default_output

    return default_output(args.experiment, args.resume)


def _start_watch(path: Path) -> None:
    """``run --watch``: serve the live page of the run file in the background and print its address."""
    from ecds_lab.live.server import serve_in_background, url_of

    print(f"live view of {path}: {url_of(serve_in_background(Path(path)))}", flush=True)


def _cmd_watch(args: argparse.Namespace) -> int:
    """Serve the live page of a run file until Ctrl-C; a file that cannot become a run file fails at once,
    one that does not exist yet is waited for at most ``--wait`` seconds (docs/live_view.md)."""
    import threading

    from ecds_lab.live.target import check_watch_target, wait_for_run_file

    exists = check_watch_target(args.run)  # before importing the page's plotting: a bad path fails at once

    from ecds_lab.live.server import make_server, url_of

    server = make_server(args.run, args.port)
    print(f"live view of {args.run}: {url_of(server)} (Ctrl-C to stop)", flush=True)
    thread = threading.Thread(target=server.serve_forever, name="live-view", daemon=True)
    thread.start()
    try:
        if not exists:
            print(f"waiting up to {args.wait:g} s for {args.run} to be created by its run "
                  f"(ecds-lab run ... -o {args.run})", flush=True)
            wait_for_run_file(args.run, args.wait)
            print(f"{args.run} created; following it", flush=True)
        while thread.is_alive():
            thread.join(timeout=3600)
    except KeyboardInterrupt:
        print("live view stopped")
    finally:
        server.shutdown()
        server.server_close()
    return 0


def _seconds(text: str) -> float:
    """A ``--wait`` value: a finite number of seconds >= 0."""
    import math

    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds >= 0")
    return value


def _cmd_list(args: argparse.Namespace) -> int:
    """Print the shipped experiments, stations and sensors by the names the other commands accept."""
    from ecds_lab.config.catalogue import format_catalogue

    print(format_catalogue())
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    output = args.output or Path(args.run).with_suffix(".csv")
    print(_export(args, output))
    return 0


def _export(args: argparse.Namespace, output: Path) -> str:
    """A run file: every column (or --columns) and the units sidecar; a CSV: the import columns.

    Never onto an input, never over an existing file without --overwrite (storage/outputs.py);
    what the reader had to work around in the run file (lost rows, a killed writer) is noted.
    """
    from ecds_lab.data.files import file_kind
    from ecds_lab.storage.data_file import open_data
    from ecds_lab.storage.export import columns_from, export_run, sidecar_path
    from ecds_lab.storage.outputs import check_output, write_output
    from ecds_lab.storage.reader import read_run

    if file_kind(args.run) == "run":
        columns = columns_from(args.columns)
        for path in (output, sidecar_path(Path(output))):
            check_output(path, [args.run], overwrite=args.overwrite)
        for note in read_run(args.run, transcripts=False).notes:
            _say(f"ecds-lab export: note: {note}")
        return export_run(args.run, output, columns).describe(output)
    data = open_data(args.run).data
    write_output(output, [args.run], args.overwrite, data.to_csv)
    return f"{len(data)} rows (one per reading) -> {output}"


def _effects(text: str | None) -> list[str]:
    return [e.strip() for e in (text or "").split(",") if e.strip()]


def _load_user_effects(files: Sequence[Path] | None) -> EffectRegistry:
    """The effects ``fit``, ``diagnose`` and ``report`` may use: the library, installed packages' and every
    ``--effects-from`` file's."""
    from ecds_lab.model.plugins import with_effects_files

    return with_effects_files(files or ())


def _cmd_fit(args: argparse.Namespace) -> int:
    from ecds_lab.analysis.summary import fit_summary, format_fit_summary
    from ecds_lab.storage.data_file import open_campaign

    registry = _load_user_effects(args.effects_from)
    opened = open_campaign(args.data, args.sensor)
    summary = {"sensor": opened.sensor_summary(),
               **fit_summary(opened.data, _effects(args.effects), opened.sensor, registry)}
    _print(summary, _notes(opened), args.json, format_fit_summary)
    return 0


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from ecds_lab.analysis.diagnosis import diagnose, format_diagnosis
    from ecds_lab.storage.data_file import open_campaign

    if args.each:
        if args.also_try:
            raise InvalidSettingError("--try applies to one campaign's diagnose, not yet to --each")
        return _diagnose_each(args)
    if args.scheduler:
        raise InvalidSettingError("--scheduler applies to diagnose --each only")
    registry = _load_user_effects(args.effects_from)
    opened = open_campaign(args.data, args.sensor)
    _require_readings(opened.data, args.data, 2, "a diagnosis compares readings")
    with forked.allowed(_worker_count(args.workers)):
        result = {"sensor": opened.sensor_summary(),
                  **diagnose(opened.data, _effects(args.effects), opened.sensor, registry=registry,
                             also_try=_effects(args.also_try))}
    _print(result, _notes(opened), args.json, format_diagnosis)
    return 0


def _diagnose_each(args: argparse.Namespace) -> int:
    """``diagnose --each``: every DATA file its own campaign, diagnosed in parallel; a table (or JSON list) out.
    Exit 1 when any campaign could not be diagnosed (its row says why)."""
    from ecds_lab.batch import diagnose_each, format_table

    _load_user_effects(args.effects_from)  # unknown names and bad effect files fail here, before any worker starts
    rows = diagnose_each(args.data, _effects(args.effects), args.sensor, effect_files=args.effects_from or (),
                         scheduler=args.scheduler, workers=args.workers)
    print(json.dumps(rows, indent=2) if args.json else format_table(rows))
    return 1 if any(row.get("error") for row in rows) else 0


def _worker_count(workers: int | None) -> int | None:
    """``--workers`` for one campaign's analysis: processes for its independent fits (``forked``); None: every CPU."""
    if workers is not None and workers < 1:
        raise InvalidSettingError(f"--workers must be at least 1, got {workers}")
    return workers


def _require_readings(data: Sized, paths: Sequence[Path], minimum: int, why: str) -> None:
    """Refuse data too small for the analysis asked, naming the file and the count."""
    from ecds_lab.data.measurements import DataError

    if len(data) < minimum:
        named = ", ".join(str(p) for p in paths)
        raise DataError(f"{named}: {len(data)} reading(s); {why} and needs at least {minimum}")


def _notes(opened: Campaign) -> list[str]:
    """What the output says before its analysis: the sensor assumed, units that look wrong for the data contract."""
    from ecds_lab.analysis.suspect_units import unit_notes

    return [note for note in (opened.sensor_note, *unit_notes(opened.data, opened.sensor)) if note]


def _print(result: dict, notes: list[str], as_json: bool, as_text: Callable[[dict], str]) -> None:
    """One JSON object (the notes under ``notes``), or the text headed by the sensor and the notes."""
    if as_json:
        print(json.dumps({**result, "notes": notes} if notes else result, indent=2))
        return
    sensor = result["sensor"]
    head = f"sensor: {sensor['name']} ({sensor['target']} target; {sensor['source']})\n"
    print(head + "".join(f"note: {note}\n" for note in notes) + as_text(result))


def _cmd_report(args: argparse.Namespace) -> int:
    from ecds_lab.analysis.blas_threads import one_blas_thread
    from ecds_lab.report.html import write_report
    from ecds_lab.storage.outputs import check_output, write_output

    registry = _load_user_effects(args.effects_from)
    inputs = [Path(p) for p in args.data]
    check_output(args.output, inputs, overwrite=args.overwrite)  # before minutes of analysis
    # as the fit and the diagnosis: tall, thin matrices, slowed by BLAS threads on busy cores; the diagnosis's
    # independent fits on every CPU
    with one_blas_thread(), forked.allowed():
        write_output(args.output, inputs, args.overwrite,
                     lambda path: write_report(inputs, path, effects=registry, investigation=args.investigation))
    print(f"report -> {args.output}")
    return 0


def _station_config(reference: Path | None) -> tuple[Path, object]:
    from ecds_lab.config.loading import parse_yaml, read_text, validate
    from ecds_lab.config.references import station_path
    from ecds_lab.config.station import StationConfig

    path = station_path(reference)
    return path, validate(str(path), parse_yaml(read_text(path), str(path)), StationConfig)


def _cmd_plan_next(args: argparse.Namespace) -> int:
    """``plan-next``: the experiment that best separates the diagnosis's competing models (docs/planning.md)."""
    from ecds_lab.analysis.diagnosis import run_diagnosis
    from ecds_lab.planning.choice import plan_next, write_experiment
    from ecds_lab.storage.data_file import open_campaign
    from ecds_lab.storage.outputs import check_output

    registry = _load_user_effects(args.effects_from)
    _, station = _station_config(args.station)
    if args.output is not None:
        check_output(args.output, list(args.data), overwrite=args.overwrite)
    opened = open_campaign(args.data, args.sensor)
    _require_readings(opened.data, args.data, 2, "a plan starts from a diagnosis")
    with forked.allowed():
        result = run_diagnosis(opened.data, (), opened.sensor, registry=registry)
    plan = plan_next(result, registry, station, args.max_hours, runs=args.data)  # type: ignore[arg-type]
    if args.json:
        print(json.dumps(plan.to_json(), indent=2))
    else:
        print(f"verdict: {result.verdict}")
        for index, question in enumerate(plan.questions):
            print(f"open question ({question.kind}): {question.text}")
            if index in plan.decided:
                print(f"  decided: {plan.decided[index]}")
        if plan.chosen is not None:
            print(f"chosen: {plan.chosen.candidate.what} ({plan.chosen.candidate.hours:.2f} h of lab time), "
                  f"predicted Delta chi-square {plan.predicted_delta_chi2:.1f}")
        print(f"why: {plan.why}")
    if plan.chosen is not None and args.output is not None:
        write_experiment(plan, args.output)
        print(f"experiment -> {args.output}" if not args.json else "", file=sys.stderr if args.json else sys.stdout)
    return 0


def _cmd_investigate(args: argparse.Namespace) -> int:
    """``investigate``: diagnose -> plan-next -> run -> diagnose until decided or the budget is spent."""
    from ecds_lab.planning.investigate import investigate

    station_file, station = _station_config(args.station)
    simulated = getattr(station, "simulated", None) is not None
    confirm = None if args.yes or simulated else _ask
    state = investigate(args.data, station_file, args.output, budget_hours=args.budget_hours, confirm=confirm,
                        registry=_load_user_effects(args.effects_from))
    final = state.final or {}
    print(f"stopped: {state.stopped}")
    print(f"final verdict: {final.get('verdict')}; claimed: {', '.join(final.get('claimed', [])) or 'nothing'}; "
          f"{state.hours_spent:.2f} h of lab time; {args.output / 'investigate.json'}")
    last = state.rounds[-1] if state.rounds else {}
    if last.get("run_status") == "aborted" and last.get("stopped_by") is not None:
        from ecds_lab.runner.safe_state import exit_code

        return exit_code(int(last["stopped_by"]))
    return 0


def _ask(question: str) -> bool:
    try:
        return input(f"{question} [y/N] ").strip().lower() in ("y", "yes")
    except EOFError:
        return False


def _hours(text: str) -> float:
    import math

    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of hours > 0")
    return value


def _cmd_replay(args: argparse.Namespace) -> int:
    from ecds_lab.replay import format_replay, replay_run

    result = replay_run(args.run)
    print(format_replay(result))
    return 0 if result.reproduced else 1


def _cmd_demo(args: argparse.Namespace) -> int:
    from ecds_lab.demo import run_demo

    run_demo(args.output, progress=not args.quiet)
    return 0


def _cmd_simulate(args: argparse.Namespace) -> int:
    """Serve the simulated lab's instruments on local ports until Ctrl-C (docs/simulate.md)."""
    from ecds_lab.errors import ConfigError
    from ecds_lab.instruments.kinds import ROLE_NAMES
    from ecds_lab.simulators.serve import LabServer
    from ecds_lab.station import load_station_config

    config, _ = load_station_config(args.station)
    if config.simulated is None:
        raise ConfigError("simulate: the station has no 'simulated' section; give a simulated station YAML "
                          "or a shipped one's name (e.g. simulated_lab; see ecds-lab list)")
    drivers: dict[str, str] = {role: getattr(config, role).driver for role in ROLE_NAMES}
    server = LabServer(config.simulated.lab, drivers, port_base=args.port_base, serial=args.serial)
    try:
        print(server.describe())
        print("serving the simulated lab (time runs with the wall clock); Ctrl-C stops", flush=True)
        server.serve_forever()
    finally:
        server.close()
    return 0


def _simulate_parser(command: Callable[..., argparse.ArgumentParser]) -> None:
    p = command("simulate", _cmd_simulate, "serve the simulated lab's instruments to any client: SCPI instruments "
                "on raw sockets (5025 and up), serial ones on pseudo-terminals, until Ctrl-C")
    p.add_argument("--station", type=Path, help="simulated station YAML, or a shipped station's name "
                   "(default: simulated_lab, shipped)")
    p.add_argument("--port-base", type=int, default=5025, metavar="PORT",
                   help="first TCP port (default 5025, the LXI raw-socket port); 0 lets the system choose")
    p.add_argument("--serial", choices=("pty", "tcp"), default="pty" if hasattr(os, "openpty") else "tcp",
                   help="serial instruments on pseudo-terminals (default on POSIX) or TCP ports for pyserial's "
                        "socket:// (default elsewhere)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="ecds-lab", description="Run an eddy current displacement sensor lab "
                                     "(HM8118, GRBL slide, DAQ970A, HMP) and explain its data.")
    parser.add_argument("--version", action="version", version=f"ecds-lab {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log every step")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def command(name: str, handler: Callable[[argparse.Namespace], int], help_text: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(handler=handler)
        return p

    p = command("run", _cmd_run, "run an experiment YAML on a station (default: the simulated lab)")
    p.add_argument("experiment", type=Path, help="experiment YAML, or a shipped experiment's name such as "
                   "displacement_sweep (see: ecds-lab list)")
    p.add_argument("--station", type=Path, help="station YAML, or a shipped station's name "
                   "(default: simulated_lab, shipped)")
    p.add_argument("-o", "--output", type=Path, help="run file to write (.h5)")
    p.add_argument("--resume", type=Path, metavar="RUN.h5", help="continue an interrupted run into a new file")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file")
    p.add_argument("--dry-run", action="store_true", help="print the plan; touch no instrument")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.add_argument("--watch", action="store_true", help="serve a live page of the run on 127.0.0.1 (see watch)")

    p = command("demo", _cmd_demo, "the whole paper campaign on the simulated lab, then analysis and report")
    p.add_argument("-o", "--output", type=Path, default=Path("ecds-demo"), help="output folder")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")

    p = command("fit", _cmd_fit, "fit the model (baseline plus named effects) to DATA (.h5 run files or CSVs: one "
                "campaign)")
    p.add_argument("data", type=Path, nargs="+")
    p.add_argument("--effects", help="comma-separated effect names to add to the baseline")
    p.add_argument("--effects-from", type=Path, action="append", metavar="FILE.py",
                   help="a Python file of your own effects (Effect subclasses); may be given several times")
    p.add_argument("--sensor", help="sensor YAML (a path, or a shipped name such as steel_target); "
                   "overrides the sensor a run file records (default: the recorded sensor, else the paper's prototype)")
    p.add_argument("--json", action="store_true", help="print one JSON object")

    p = command("diagnose", _cmd_diagnose, "where the model fails on DATA (one campaign) and which effect is missing")
    p.add_argument("data", type=Path, nargs="+")
    p.add_argument("--each", action="store_true",
                   help="every DATA file is its own campaign: one diagnosis each, in parallel (Dask), a table out")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="with --each: a Dask scheduler (tcp://host:8786) instead of a local cluster")
    p.add_argument("--workers", type=int, metavar="N",
                   help="with --each: local Dask worker processes; otherwise: processes for the diagnosis's "
                   "independent fits (default: one per CPU)")
    p.add_argument("--effects", help="effects already added to the baseline (diagnose what is still missing)")
    p.add_argument("--try", dest="also_try", metavar="EFFECTS",
                   help="comma-separated effects not tried by default to try as well (e.g. plate_recession, on a "
                   "thick plate measured at two frequencies or more; docs/diagnosis.md)")
    p.add_argument("--effects-from", type=Path, action="append", metavar="FILE.py",
                   help="a Python file of your own effects (Effect subclasses); may be given several times")
    p.add_argument("--sensor", help="sensor YAML (a path, or a shipped name such as steel_target); "
                   "overrides the sensor a run file records (default: the recorded sensor, else the paper's prototype)")
    p.add_argument("--json", action="store_true", help="print one JSON object")

    p = command("report", _cmd_report, "write a self-contained HTML report with plots")
    p.add_argument("data", type=Path, nargs="+", help="run files or CSV")
    p.add_argument("-o", "--output", type=Path, default=Path("report.html"))
    p.add_argument("--effects-from", type=Path, action="append", metavar="FILE.py",
                   help="a Python file of your own effects (Effect subclasses); may be given several times")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file (never an input)")
    p.add_argument("--investigation", type=Path, metavar="investigate.json", help="the record of an "
                   "ecds-lab investigate loop, for the chapter 'How the question was decided' (default: one found "
                   "beside the data files)")

    p = command("plan-next", _cmd_plan_next, "design the experiment that best separates the models the diagnosis "
                "of DATA leaves open (T-optimal, per hour of lab time); write it as an experiment YAML")
    p.add_argument("data", type=Path, nargs="+")
    p.add_argument("--station", type=Path, help="station YAML or shipped name (default: simulated_lab)")
    p.add_argument("-o", "--output", type=Path, help="experiment YAML to write")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file (never an input)")
    p.add_argument("--max-hours", type=_hours, metavar="H", help="only experiments of at most H hours of lab time")
    p.add_argument("--sensor", help="sensor YAML or shipped name (as for diagnose)")
    p.add_argument("--effects-from", type=Path, action="append", metavar="FILE.py")
    p.add_argument("--json", action="store_true", help="print the open questions, candidates and choice as JSON")

    p = command("investigate", _cmd_investigate, "the loop: diagnose, plan the deciding experiment, run it, add it to "
                "the campaign, diagnose again, until no open question is left or the budget is spent")
    p.add_argument("data", type=Path, nargs="+")
    p.add_argument("--station", type=Path, required=True, help="station YAML or shipped name")
    p.add_argument("--budget-hours", type=_hours, metavar="H", help="lab hours the loop may spend")
    p.add_argument("--yes", action="store_true", help="run each round without asking (a real station asks)")
    p.add_argument("-o", "--output", type=Path, default=Path("investigation"), help="folder for every round's "
                   "files and investigate.json")
    p.add_argument("--effects-from", type=Path, action="append", metavar="FILE.py")

    p = command("replay", _cmd_replay, "re-run a recorded session through the drivers from its transcript")
    p.add_argument("run", type=Path)

    _simulate_parser(command)

    p = command("watch", _cmd_watch, "serve a live web page of a run file on 127.0.0.1 while it is written")
    p.add_argument("run", type=Path, help="run file (.h5); if it does not exist yet, watch waits for its run "
                   "to create it (see --wait)")
    p.add_argument("--port", type=int, default=0, help="port (default: a free one, printed)")
    p.add_argument("--wait", type=_seconds, default=60.0, metavar="SECONDS",
                   help="how long to wait for a run file that does not exist yet before giving up "
                   "(default: 60; 0: do not wait)")

    command("list", _cmd_list, "what ships with ecds-lab: experiments (with kind), stations and sensors, "
            "each usable by name from any folder")

    p = command("export", _cmd_export, "write a run's readings as CSV, one row per reading: the import format's "
                "columns first, then every other column; units, directions and the station's figures in "
                "RUN.units.json")
    p.add_argument("run", type=Path)
    p.add_argument("-o", "--output", type=Path)
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file (never an input)")
    p.add_argument("--columns", help="comma-separated columns to write (default: all)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    parser.add_argument("--debug", action="store_true",
                        help="show the Python traceback of an unexpected error (also ECDS_LAB_DEBUG=1)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    return _guarded(args)


def _guarded(args: argparse.Namespace) -> int:
    """Run a command (see :func:`_run_guarded`), then leave at once if a run file failed a write."""
    code = _run_guarded(args)
    _exit_now_if_a_run_file_broke(code)
    return code


def _exit_now_if_a_run_file_broke(code: int) -> None:
    """After a failed write (full disk) the HDF5 library retries its unwritable metadata whenever an
    object is freed and can crash at interpreter exit; what was flushed is on disk, so end here."""
    run_file = sys.modules.get("ecds_lab.storage.run_file")
    if run_file is not None and run_file.BROKEN_WRITERS:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except OSError:
                pass
        os._exit(code or 1)


def _run_guarded(args: argparse.Namespace) -> int:
    """Run a command; every failure becomes one line on stderr and a non-zero exit, never a traceback.

    Expected failures (bad input, a file or instrument problem) exit 2; a signal 128 + its number;
    anything else is a bug: one line asking for a report, the traceback only with --debug.
    """
    from ecds_lab.runner.safe_state import StopSignal, exit_code, signal_name

    name = f"ecds-lab {args.command}"
    try:
        return args.handler(args)
    except (EcdsLabError, ValueError) as exc:
        _say(f"{name}: {exc}")
        return 2
    except BrokenPipeError:
        _quiet_stdout()  # the reader (head, less) has gone: nothing to say, nothing to flush
        return 0
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        _say(f"{name}: {where}{exc.strerror or exc}")
        return 2
    except KeyboardInterrupt:
        _say(f"{name}: interrupted")
        return exit_code(signal.SIGINT)
    except StopSignal as stop:
        _say(f"{name}: stopped by {signal_name(stop.signum)}")
        return exit_code(stop.signum)
    except Exception as exc:  # a bug: visible, but as one line unless asked for more
        if getattr(args, "debug", False) or os.environ.get("ECDS_LAB_DEBUG") == "1":
            traceback.print_exc()
        _say(f"{name}: unexpected error {type(exc).__name__}: {exc} -- this is a bug in ecds-lab, please report "
             "it (run again with --debug or ECDS_LAB_DEBUG=1 for the details)")
        return 70


def _say(line: str) -> None:
    try:
        print(line, file=sys.stderr)
    except OSError:
        pass


def _quiet_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush does not raise BrokenPipeError again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    sys.exit(main())
