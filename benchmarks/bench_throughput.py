"""End-to-end throughput: drivers, transports, protocol emulators, runner and HDF5 (every point flushed).

Runs a displacement sweep on the default simulated station (bridge and slide over pyserial,
scanner and supply over pyvisa-py) with instant time and no pacing, and prints points/s and
microseconds per point: for the measuring loop (first to last point, from the run file's wall
clock) and for the whole command including start-up, next to the issue's yardstick measured in
the same process (a plain h5py resize-write-flush loop, ~15,000 points/s when the issue was written;
this shared machine's speed varies by tens of percent). Target (issue 3): >= 5,000 points/s.
Issue 17: the full stack stays within 1.5x of the plain h5py per-point loop and ahead of QCoDeS's
dond (printed beside it when qcodes is installed: pip install qcodes; skipped otherwise), and the
run file's own per-point cost (RunWriter.append with the live NeXus views) is printed on its own.
Usage: python benchmarks/bench_throughput.py [--points N] [--speed fast|medium|slow] [--profile]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
import yaml

from ecds_lab.runner.session import run_experiment
from ecds_lab.station import DEFAULT_STATION
from ecds_lab.storage.reader import read_run


def sweep_yaml(points: int, speed: str) -> dict:
    """A sweep of 50 positions x 2 frequencies x 10 readings, repeated to about ``points`` readings."""
    positions = [20.0 + i for i in range(50)]
    repeats = max(1, round(points / (len(positions) * 2 * 10)))
    return {"kind": "displacement_sweep", "name": "throughput", "home_first": True, "bridge": {"speed": speed},
            "sweep": {"positions_mm": positions, "frequencies_hz": [500, 15000], "direction": "forward",
                      "readings_per_point": 10, "repeats": repeats, "settle_s": 0.0}}


def plain_h5py_points_per_s(folder: Path, points: int = 20_000) -> float:
    """The issue's yardstick: a plain h5py loop that resizes, writes and flushes one row per point."""
    with h5py.File(folder / "plain.h5", "w", libver="latest") as f:
        table = f.create_dataset("points", shape=(0, 19), maxshape=(None, 19), dtype="f8", chunks=(32, 19))
        f.swmr_mode = True
        row = np.zeros(19)
        start = time.perf_counter()
        for i in range(points):
            table.resize((i + 1, 19))
            table[i] = row
            table.flush()
        return points / (time.perf_counter() - start)


def run_writer_points_per_s(folder: Path, points: int = 20_000) -> float:
    """The run file alone: RunWriter.append of full rows (a sweep's file, with its live NeXus views)."""
    from ecds_lab.data.columns import COLUMN_NAMES
    from ecds_lab.storage.run_file import RunWriter, metadata_for

    experiment = yaml.safe_dump(sweep_yaml(points, "slow"))
    writer = RunWriter(folder / "writer.h5", metadata=metadata_for(experiment, "", "throughput", "displacement_sweep"),
                       transcripts={}, overwrite=True)
    row = {name: 1.0 for name in COLUMN_NAMES}
    start = time.perf_counter()
    for _ in range(points):
        writer.append(row)
    rate = points / (time.perf_counter() - start)
    writer.close("completed")
    return rate


def qcodes_dond_points_per_s(folder: Path, points: int = 5_000) -> float | None:
    """QCoDeS's dond sweeping one parameter and reading 18 (19 columns), into its SQLite dataset; None if absent."""
    try:
        from qcodes.dataset import LinSweep, dond, initialise_or_create_database_at, load_or_create_experiment
        from qcodes.parameters import ManualParameter, Parameter
    except ImportError:
        return None
    initialise_or_create_database_at(folder / "qcodes.db")
    load_or_create_experiment("throughput", sample_name="bench")
    x = ManualParameter("x", initial_value=0.0)
    readings = [Parameter(f"p{i}", get_cmd=lambda: 1.0) for i in range(18)]
    start = time.perf_counter()
    dond(LinSweep(x, 0.0, 1.0, points, 0.0), *readings, do_plot=False, show_progress=False)
    return points / (time.perf_counter() - start)


def run_once(folder: Path, points: int, speed: str, profiler: cProfile.Profile | None) -> tuple[float, float, int]:
    """One sweep into a fresh run file: (loop s/point, whole-command s/point, points)."""
    (folder / "sweep.yaml").write_text(yaml.safe_dump(sweep_yaml(points, speed)))
    output = folder / "run.h5"
    output.unlink(missing_ok=True)
    start = time.perf_counter()
    if profiler:
        profiler.enable()
    result = run_experiment(folder / "sweep.yaml", folder / "station.yaml", output, progress=False)
    if profiler:
        profiler.disable()
    elapsed = time.perf_counter() - start
    if result.status != "completed":
        raise SystemExit(f"benchmark run {result.status}: {result.error}")
    wall = read_run(output, transcripts=False).column("wall_time_s")
    return (wall[-1] - wall[0]) / (len(wall) - 1), elapsed / result.points, result.points


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--points", type=int, default=20_000)
    parser.add_argument("--speed", choices=("fast", "medium", "slow"), default="slow",
                        help="bridge speed: sets how much simulated time a reading takes, and so how often "
                             "temperatures (re-read when older than 2 s) are scanned")
    parser.add_argument("--repeat", type=int, default=3, help="runs; the median is the figure (the machine is shared)")
    parser.add_argument("--profile", action="store_true", help="print the top functions by own time")
    args = parser.parse_args()
    profiler = cProfile.Profile() if args.profile else None
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        station = yaml.safe_load(DEFAULT_STATION.read_text())
        station["simulated"]["pacing"] = False
        station["simulated"]["real_time_factor"] = 0.0
        (folder / "station.yaml").write_text(yaml.safe_dump(station))
        runs = [run_once(folder, args.points, args.speed, profiler) for _ in range(args.repeat)]
        plain = sorted(plain_h5py_points_per_s(folder) for _ in range(args.repeat))[args.repeat // 2]
        writer = sorted(run_writer_points_per_s(folder) for _ in range(args.repeat))[args.repeat // 2]
        dond_rate = qcodes_dond_points_per_s(folder)
    loops = sorted(r[0] for r in runs)
    wholes = sorted(r[1] for r in runs)
    print(f"{runs[0][2]} points per run, {len(runs)} runs, bridge speed {args.speed}, instant time, no pacing")
    print("measuring loop (first to last point): " + ", ".join(f"{1 / t:,.0f}" for t, _, _ in runs)
          + f" points/s; median {1 / loops[len(loops) // 2]:,.0f} points/s = "
          f"{loops[len(loops) // 2] * 1e6:.1f} us/point")
    print("whole command incl. start-up and close: " + ", ".join(f"{1 / t:,.0f}" for _, t, _ in runs)
          + f" points/s; median {1 / wholes[len(wholes) // 2]:,.0f} points/s = "
            f"{wholes[len(wholes) // 2] * 1e6:.1f} us/point")
    loop_rate = 1 / loops[len(loops) // 2]
    print(f"plain h5py loop on this machine now (median): {plain:,.0f} points/s; the measuring loop runs at "
          f"{loop_rate / plain:.2f} of it (target 5,000 of ~15,000 = 0.33; scaled to a 15,000 points/s "
          f"machine: {loop_rate / plain * 15_000:,.0f} points/s)")
    print(f"per point: ecds-lab full stack {loops[len(loops) // 2] * 1e6:.1f} us, plain h5py loop "
          f"{1e6 / plain:.1f} us (ratio {loops[len(loops) // 2] * plain:.2f}, target <= 1.5), run file alone "
          f"(RunWriter.append, live NeXus views) {1e6 / writer:.1f} us")
    if dond_rate is None:
        print("QCoDeS dond: not installed (pip install qcodes to compare)")
    else:
        print(f"QCoDeS dond (19 columns, SQLite, trivial parameters): {1e6 / dond_rate:.1f} us/point; "
              f"ecds-lab full stack is {1e6 / dond_rate / (loops[len(loops) // 2] * 1e6):.1f}x faster")
    if profiler:
        pstats.Stats(profiler).sort_stats("tottime").print_stats(25)


if __name__ == "__main__":
    main()
