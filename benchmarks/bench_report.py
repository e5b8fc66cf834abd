"""Benchmark: time ``write_report`` on a ~1,000-reading simulated campaign; print the figures.

Run: ``python benchmarks/bench_report.py [--source csv|runs|large|both] [--size N] [--repeat N]``.
Not a timed test; targets: a report in under 15 s for the ~1,000-reading campaigns, and in under
30 s for 100,000 readings (``large``: paper campaigns with different seeds as CSV files of one
campaign, issue 15). Printed per campaign: the whole report as
``ecds-lab report`` writes it (diagnosis included), the diagnosis alone, and the report with a
ready diagnosis passed in (loading, analysis, figures, page).

Campaigns: ``csv`` is the paper's experiments in one simulated recording (``paper_campaign``,
1,144 readings) as a CSV import; ``runs`` is every shipped experiment run through the real
drivers into run files (what ``ecds-lab demo`` reports on: sweep, coil heating, spectroscopy,
copper and steel target heating).
"""

from __future__ import annotations

import argparse
import functools
import os
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from ecds_lab import shipped
from ecds_lab.report.findings import target_groups
from ecds_lab.report.html import write_report
from ecds_lab.report.inputs import load_inputs

EXPERIMENTS = shipped.experiments_folder()
T = TypeVar("T")
RUNS = (("displacement_sweep.yaml", "simulated_lab.yaml"), ("coil_heating.yaml", "simulated_lab_in_air.yaml"),
        ("spectroscopy.yaml", "simulated_lab_in_air.yaml"), ("target_heating_copper.yaml", "simulated_lab.yaml"),
        ("target_heating_steel.yaml", "simulated_lab_steel.yaml"))


def csv_campaign(folder: Path) -> list[Path]:
    from ecds_lab.simulators.campaign import paper_campaign

    path = folder / "paper_campaign.csv"
    paper_campaign(seed=0).to_csv(path)
    return [path]


def large_campaign(folder: Path, size: int) -> list[Path]:
    """Paper campaigns (different seeds) as CSV files of one campaign, ``size`` readings in all."""
    from ecds_lab.simulators.campaign import paper_campaign

    paths, total, seed = [], 0, 0
    while total < size:
        data = paper_campaign(seed=seed)
        data = data.select(slice(0, min(len(data), size - total)))
        path = folder / f"paper_campaign_{seed}.csv"
        data.to_csv(path)
        paths.append(path)
        total, seed = total + len(data), seed + 1
    return paths


def run_campaign(folder: Path) -> list[Path]:
    from ecds_lab.runner.session import run_experiment

    paths = []
    for experiment, station in RUNS:
        output = folder / experiment.replace(".yaml", ".h5")
        run_experiment(EXPERIMENTS / experiment, EXPERIMENTS / "stations" / station, output, progress=False)
        paths.append(output)
    return paths


def timed(action: Callable[[], T], repeat: int) -> tuple[float, T]:
    """The median wall time of ``repeat`` calls and the last call's result."""
    times = []
    for _ in range(repeat):
        began = time.perf_counter()
        result = action()
        times.append(time.perf_counter() - began)
    return statistics.median(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--source", choices=("csv", "runs", "both", "large"), default="both")
    parser.add_argument("--size", type=int, default=100_000, help="readings of the large campaign")
    parser.add_argument("--repeat", type=int, default=1, help="reports to time (median)")
    args = parser.parse_args()
    from ecds_lab.analysis.diagnosis import run_diagnosis

    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"{cpus} CPU(s) available")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for source in (("csv", "runs", "large") if args.source == "both" else (args.source,)):
            paths = (csv_campaign(folder) if source == "csv" else run_campaign(folder) if source == "runs"
                     else large_campaign(folder, args.size))
            inputs = load_inputs(paths)
            readings = sum(len(i.data) for i in inputs)
            main_group = target_groups([i for i in inputs if not i.is_spectroscopy])[0]
            output = folder / f"report-{source}.html"
            whole, _ = timed(functools.partial(write_report, paths, output), args.repeat)
            diagnosis_s, diagnosis = timed(functools.partial(run_diagnosis, main_group.data,
                                                             sensor=main_group.fit.model.sensor), args.repeat)
            rest, _ = timed(functools.partial(write_report, paths, output, diagnosis=diagnosis), args.repeat)
            print(f"{source}: {readings} readings in {len(paths)} file(s) -> {output.stat().st_size / 1e6:.1f} MB")
            print(f"  report as `ecds-lab report` writes it: {whole:.1f} s  (target: under "
                  f"{30 if source == 'large' else 15} s)")
            print(f"  of which the diagnosis alone takes:    {diagnosis_s:.1f} s "
                  f"({len(main_group.data)} readings of the {main_group.material} target)")
            print(f"  report with the diagnosis given:       {rest:.1f} s")


if __name__ == "__main__":
    main()
