"""The ``ecds-lab`` command line (DESIGN.md): run, demo, fit, diagnose, report, replay, export."""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Sequence

from ecds_lab import __version__
from ecds_lab.errors import EcdsLabError

if TYPE_CHECKING:
    from ecds_lab.analysis.dataset import Measurements

log = logging.getLogger("ecds_lab")


def _cmd_run(args: argparse.Namespace) -> int:
    from ecds_lab.runner.session import prepare, run_experiment

    if args.dry_run:
        *_, plan = prepare(args.experiment, args.station)
        print(plan.describe())
        return 0
    result = run_experiment(args.experiment, args.station, args.output, resume=args.resume,
                            overwrite=args.overwrite, progress=not args.quiet)
    print(f"{result.status}: {result.points} points in {result.path} ({result.wall_s:.1f} s)")
    if result.error:
        print(f"error: {result.error}", file=sys.stderr)
    return 0 if result.status == "completed" else 1


def _cmd_export(args: argparse.Namespace) -> int:
    from ecds_lab.analysis.dataset import load_measurements

    data = load_measurements(args.run)
    output = args.output or Path(args.run).with_suffix(".csv")
    data.to_csv(output)
    print(f"{len(data)} rows -> {output}")
    return 0


def _sensor(data: Path, sensor: Path | None):  # noqa: ANN202 - SensorConfig, imported late
    """The sensor of DATA: ``--sensor`` if given, else a run file's simulated lab's, else the paper's prototype."""
    from ecds_lab.model.sensor import SensorConfig, load_sensor

    if sensor is not None:
        return load_sensor(sensor)
    if data.suffix.lower() in (".h5", ".hdf5", ".nxs"):
        import yaml

        from ecds_lab.storage.reader import read_run

        station = yaml.safe_load(read_run(data, transcripts=False).metadata.get("station_yaml") or "{}") or {}
        block = ((station.get("simulated") or {}).get("lab") or {}).get("sensor")
        if isinstance(block, dict):
            return SensorConfig(**block)
    return SensorConfig()


def _load_user_effects(files: Sequence[Path] | None) -> None:
    """Register the effects of every ``--effects-from`` file (installed packages' come with the library)."""
    from ecds_lab.model.plugins import load_effects_file

    for path in files or ():
        load_effects_file(path)


def _campaign(paths: Sequence[Path]) -> "Measurements":
    """Several DATA files as one campaign (each its own recording)."""
    from ecds_lab.analysis.dataset import Measurements, load_measurements

    parts = [load_measurements(p) for p in paths]
    return parts[0] if len(parts) == 1 else Measurements.concatenate(parts)


def _cmd_fit(args: argparse.Namespace) -> int:
    from ecds_lab.analysis.summary import fit_summary, format_fit_summary

    _load_user_effects(args.effects_from)
    effects = [e.strip() for e in (args.effects or "").split(",") if e.strip()]
    summary = fit_summary(_campaign(args.data), effects, _sensor(args.data[0], args.sensor))
    print(json.dumps(summary, indent=2) if args.json else format_fit_summary(summary))
    return 0


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from ecds_lab.analysis.diagnosis import diagnose, format_diagnosis

    _load_user_effects(args.effects_from)
    effects = [e.strip() for e in (args.effects or "").split(",") if e.strip()]
    result = diagnose(_campaign(args.data), effects, _sensor(args.data[0], args.sensor))
    print(json.dumps(result, indent=2) if args.json else format_diagnosis(result))
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from ecds_lab.report.html import write_report

    _load_user_effects(args.effects_from)
    output = write_report([Path(p) for p in args.data], args.output)
    print(f"report -> {output}")
    return 0


def _cmd_replay(args: argparse.Namespace) -> int:
    from ecds_lab.replay import format_replay, replay_run

    result = replay_run(args.run)
    print(format_replay(result))
    return 0 if result.reproduced else 1


def _cmd_demo(args: argparse.Namespace) -> int:
    from ecds_lab.demo import run_demo

    run_demo(args.output, progress=not args.quiet)
    return 0


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
    p.add_argument("experiment", type=Path, help="experiment YAML")
    p.add_argument("--station", type=Path, help="station YAML (default: experiments/stations/simulated_lab.yaml)")
    p.add_argument("-o", "--output", type=Path, help="run file to write (.h5)")
    p.add_argument("--resume", type=Path, metavar="RUN.h5", help="continue an interrupted run into a new file")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file")
    p.add_argument("--dry-run", action="store_true", help="print the plan; touch no instrument")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")

    p = command("demo", _cmd_demo, "the whole paper campaign on the simulated lab, then analysis and report")
    p.add_argument("-o", "--output", type=Path, default=Path("ecds-demo"), help="output folder")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")

    p = command("fit", _cmd_fit, "fit the model (baseline plus named effects) to DATA (.h5 run files or CSVs: one "
                "campaign)")
    p.add_argument("data", type=Path, nargs="+")
    p.add_argument("--effects", help="comma-separated effect names to add to the baseline")
    p.add_argument("--effects-from", type=Path, action="append", metavar="FILE.py",
                   help="a Python file of your own effects (Effect subclasses); may be given several times")
    p.add_argument("--sensor", type=Path, help="sensor YAML (default: the paper's prototype, copper target)")
    p.add_argument("--json", action="store_true", help="print one JSON object")

    p = command("diagnose", _cmd_diagnose, "where the model fails on DATA (one campaign) and which effect is missing")
    p.add_argument("data", type=Path, nargs="+")
    p.add_argument("--effects", help="effects already added to the baseline (diagnose what is still missing)")
    p.add_argument("--effects-from", type=Path, action="append", metavar="FILE.py",
                   help="a Python file of your own effects (Effect subclasses); may be given several times")
    p.add_argument("--sensor", type=Path, help="sensor YAML (default: the paper's prototype, copper target)")
    p.add_argument("--json", action="store_true", help="print one JSON object")

    p = command("report", _cmd_report, "write a self-contained HTML report with plots")
    p.add_argument("data", type=Path, nargs="+", help="run files or CSV")
    p.add_argument("-o", "--output", type=Path, default=Path("report.html"))
    p.add_argument("--effects-from", type=Path, action="append", metavar="FILE.py",
                   help="a Python file of your own effects (Effect subclasses); may be given several times")

    p = command("replay", _cmd_replay, "re-run a recorded session through the drivers from its transcript")
    p.add_argument("run", type=Path)

    p = command("export", _cmd_export, "write a run's points in the CSV import format")
    p.add_argument("run", type=Path)
    p.add_argument("-o", "--output", type=Path)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        return args.handler(args)
    except (EcdsLabError, ValueError) as exc:
        print(f"ecds-lab {args.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"ecds-lab {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
