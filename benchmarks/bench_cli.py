"""Benchmark what a user runs: `ecds-lab fit`, `diagnose` and `report` as subprocesses, on campaigns of growing size.

Campaigns come from the shipped simulated station (experiments/stations/simulated_lab.yaml): the faithful
lab with its imperfections on (``physics: field``), and for comparison the same station on the exact-model
lab (``physics: ecm``, where the analysis model is exact). Each is one continuous recording of the paper's
campaign (``simulators.campaign.paper_campaign``) stretched to the size asked for: a denser displacement
grid (one reading per position and frequency) and denser logging while heating. Inputs are cached in
``--cache`` (a CSV in the import format and a run file per lab and size), since 10^6 faithful-lab readings
take a minute or two to simulate.

Per command, lab, input kind and size it prints the child's wall time, CPU time (user + sys, which tells
the cost when other work shares the cores) and peak memory (ru_maxrss of the child), then the growth
exponent d ln(wall) / d ln(n) from 10^4 to the largest size run (1: linear).
Targets (issue 25, this 2-core machine): fit of 10^5 faithful-lab readings < 5 s, of 10^6 < 60 s;
diagnose of 10^5 < 30 s, of 10^6 < 5 min; report of 10^5 < 60 s; growth no faster than linear.

Usage: python benchmarks/bench_cli.py [--sizes 1000,10000,100000,1000000] [--max-size N]
       [--labs field,ecm] [--inputs csv,run] [--commands fit,diagnose,report] [--timeout S]
       [--ecds-lab "PYTHON -m ecds_lab.cli"] [--cache DIR]
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ecds_lab import shipped
from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.station import StationConfig
from ecds_lab.data.columns import COLUMN_NAMES, INDEX, PLANNED_POINT
from ecds_lab.data.measurements import Measurements
from ecds_lab.simulators import campaign
from ecds_lab.storage.run_file import RunWriter, metadata_for

#: Sweep readings per position of ``paper_campaign``: four sweeps (room, two target set points, coil hot),
#: each forward and backward, at two frequencies.
_SWEEP_READINGS_PER_POSITION = 16
#: Lab time (s) of the campaign's heating and cooling phases times readings per logging step (two
#: frequencies): the default campaign logs ~608 readings there every 120 s (+2.2 s to read).
_HEATING_READING_SECONDS = 74_300.0
#: Share of a campaign's readings logged while heating (the rest are sweeps), where the logging can be that dense.
_HEATING_SHARE = 0.2
_TARGETS_S = {("fit", 100_000): 5.0, ("fit", 1_000_000): 60.0, ("diagnose", 100_000): 30.0,
              ("diagnose", 1_000_000): 300.0, ("report", 100_000): 60.0}


@dataclass
class Timing:
    """One command on one input: what the child cost."""

    command: str
    lab: str
    kind: str
    n: int
    wall_s: float
    cpu_s: float
    peak_mb: float
    status: str


def station_lab(physics: str) -> tuple[StationConfig, Any]:
    """The shipped simulated station's lab, with the physics asked for (``field`` as shipped, or ``ecm``)."""
    station = load_yaml_model(shipped.station("simulated_lab.yaml"), StationConfig)
    assert station.simulated is not None
    return station, station.simulated.lab.model_copy(update={"physics": physics})


def generate(physics: str, size: int, seed: int = 1) -> Measurements:
    """One continuous paper campaign of about ``size`` readings on the station's lab."""
    _, lab = station_lab(physics)
    positions = max(31, round((1 - _HEATING_SHARE) * size / _SWEEP_READINGS_PER_POSITION))
    interval = max(1.0, _HEATING_READING_SECONDS / (_HEATING_SHARE * size) - 2.2)
    return campaign.paper_campaign(lab, seed=seed, positions_mm=np.linspace(20.0, 100.0, positions).tolist(),
                                   interval_s=interval)


def write_run_file(data: Measurements, path: Path, physics: str) -> None:
    """The readings as a run file recording the station's sensor and slide repeatability (as ``ecds-lab run``
    would; no transcripts), written in one block."""
    station, _ = station_lab(physics)
    metadata = metadata_for("", "", f"benchmark campaign ({physics})", "campaign", sensor=station.sensor,
                            slide_repeatability_um=station.slide.repeatability_um)
    rows = np.full((len(data), len(COLUMN_NAMES)), np.nan)
    columns = {"time_s": data.time_s, "wall_time_s": data.time_s, "step": np.zeros(len(data)),
               "point": np.arange(len(data)), "kind": np.full(len(data), PLANNED_POINT),
               "x_commanded_mm": data.x_mm, "x_readback_mm": data.x_mm, "direction": data.direction,
               "freq_hz": data.freq_hz, "t_coil_c": data.t_coil_c, "t_target_c": data.t_target_c,
               "ls_h": data.ls_h, "rs_ohm": data.rs_ohm}
    for name, values in columns.items():
        rows[:, INDEX[name]] = values
    writer = RunWriter(path, metadata=metadata, transcripts={}, overwrite=True)
    writer.append_rows(rows)
    writer.close("completed")


def inputs(cache: Path, physics: str, size: int) -> dict[str, Path]:
    """The cached CSV and run file of one campaign, generated when missing."""
    csv, run = cache / f"{physics}-{size}.csv", cache / f"{physics}-{size}.h5"
    if not (csv.exists() and run.exists()):
        began = time.perf_counter()
        data = generate(physics, size)
        simulated = time.perf_counter() - began
        data.to_csv(csv.with_suffix(".tmp"))
        csv.with_suffix(".tmp").rename(csv)
        write_run_file(data, run, physics)
        print(f"# generated {physics} lab, {len(data)} readings: simulated in {simulated:.1f} s, "
              f"written in {time.perf_counter() - began - simulated:.1f} s", flush=True)
    return {"csv": csv, "run": run}


def rows_of(path: Path) -> int:
    """Readings in a cached CSV (its lines less the header)."""
    with path.open("rb") as handle:
        return sum(chunk.count(b"\n") for chunk in iter(lambda: handle.read(1 << 20), b"")) - 1


def run(argv: list[str], timeout_s: float, cwd: Path) -> tuple[float, float, float, str]:
    """Wall time, CPU time (user + sys) and peak resident memory (MB) of a child process, and how it ended.

    It runs in ``cwd`` (not a checkout, whose folder would shadow the ecds-lab installed for ``python -m``)."""
    began = time.perf_counter()
    child = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    status = "ok"
    deadline = began + timeout_s
    while True:
        pid, code, usage = os.wait4(child.pid, os.WNOHANG)
        if pid:
            break
        if time.perf_counter() > deadline:
            child.kill()
            pid, code, usage = os.wait4(child.pid, 0)
            status = f"timeout {timeout_s:g} s"
            break
        time.sleep(0.05)
    wall = time.perf_counter() - began
    child.returncode = os.waitstatus_to_exitcode(code)
    error = child.stderr.read().decode(errors="replace").strip().splitlines() if child.stderr else []
    if status == "ok" and child.returncode != 0:
        status = f"exit {child.returncode}: {error[-1] if error else ''}"
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0, status


def command_line(ecds_lab: list[str], command: str, data: Path, out: Path) -> list[str]:
    if command == "report":
        return [*ecds_lab, "report", str(data), "-o", str(out / "report.html"), "--overwrite"]
    return [*ecds_lab, command, str(data), "--json"]


def growth(timings: list[Timing], cost: str = "wall_s") -> float | None:
    """Least-squares slope of ln(cost) against ln(n) over the sizes from 10^4 up (None with fewer than two)."""
    points = [(math.log(t.n), math.log(getattr(t, cost))) for t in timings if t.n >= 9_000 and t.status == "ok"]
    if len(points) < 2:
        return None
    x, y = np.array(points).T
    return float(np.polyfit(x, y, 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="1000,10000,100000,1000000")
    parser.add_argument("--max-size", type=int, default=None, help="skip sizes above this")
    parser.add_argument("--labs", default="field,ecm", help="simulated lab physics: field (faithful), ecm")
    parser.add_argument("--inputs", default="csv,run", help="input kinds: csv, run")
    parser.add_argument("--commands", default="fit,diagnose,report")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds before a command is stopped")
    parser.add_argument("--ecds-lab", default=f"{shlex.quote(sys.executable)} -m ecds_lab.cli",
                        help="how to start ecds-lab (e.g. another checkout's venv, to compare)")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "ecds-lab-bench-cli")
    args = parser.parse_args()
    sizes = [s for s in (int(v) for v in args.sizes.split(",")) if args.max_size is None or s <= args.max_size]
    args.cache.mkdir(parents=True, exist_ok=True)
    ecds_lab = shlex.split(args.ecds_lab)
    timings: list[Timing] = []
    print(f"{'command':<9} {'lab':<6} {'input':<5} {'readings':>9} {'wall s':>8} {'CPU s':>8} {'peak MB':>8}  status")
    with tempfile.TemporaryDirectory() as out:
        for physics in args.labs.split(","):
            for size in sizes:
                files = inputs(args.cache, physics, size)
                n = rows_of(files["csv"])
                for command in args.commands.split(","):
                    for kind in args.inputs.split(","):
                        wall, cpu, peak, status = run(command_line(ecds_lab, command, files[kind], Path(out)),
                                                      args.timeout, Path(out))
                        timings.append(Timing(command, physics, kind, n, wall, cpu, peak, status))
                        target = _TARGETS_S.get((command, size)) if physics == "field" else None
                        mark = "" if target is None else f"  (target < {target:g} s)"
                        print(f"{command:<9} {physics:<6} {kind:<5} {n:>9} {wall:>8.2f} {cpu:>8.2f} {peak:>8.0f}  "
                              f"{status}{mark}; load {os.getloadavg()[0]:.1f}", flush=True)
    print("growth exponent d ln(cost) / d ln(n) from 10^4 up (1 = linear), of wall and of CPU time:")
    for physics in args.labs.split(","):
        for command in args.commands.split(","):
            for kind in args.inputs.split(","):
                chosen = [t for t in timings if (t.command, t.lab, t.kind) == (command, physics, kind)]
                wall, cpu = growth(chosen), growth(chosen, "cpu_s")
                if wall is not None and cpu is not None:
                    print(f"  {command:<9} {physics:<6} {kind:<5} wall {wall:.2f}  CPU {cpu:.2f}")


if __name__ == "__main__":
    main()
