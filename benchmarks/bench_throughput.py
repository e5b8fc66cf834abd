"""End-to-end throughput: drivers, transports, protocol emulators, runner and HDF5 (every point flushed).

Runs a displacement sweep on the default simulated station (bridge and slide over pyserial,
scanner and supply over pyvisa-py) with instant time and no pacing, and prints points/s and
microseconds per point: for the measuring loop (first to last point, from the run file's wall
clock) and for the whole command including start-up, next to the issue's yardstick measured in
the same process (a plain h5py resize-write-flush loop, ~15,000 points/s when the issue was written;
this shared machine's speed varies by tens of percent). Target (issue 3): >= 5,000 points/s.
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
    if profiler:
        pstats.Stats(profiler).sort_stats("tottime").print_stats(25)


if __name__ == "__main__":
    main()
