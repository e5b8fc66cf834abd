"""End-to-end throughput: drivers, transports, protocol emulators, runner and HDF5 (every point flushed).

Runs a displacement sweep on the default simulated station (bridge and slide over pyserial,
scanner and supply over pyvisa-py) with instant time and no pacing, and prints points/s and
microseconds per point: for the measuring loop (first to last point, from the run file's wall
clock) and for the whole command including start-up. Target (issue 3): >= 5,000 points/s.
Usage: python benchmarks/bench_throughput.py [--points N] [--speed fast|medium|slow] [--profile]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
import time
from pathlib import Path

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--points", type=int, default=20_000)
    parser.add_argument("--speed", choices=("fast", "medium", "slow"), default="slow",
                        help="bridge speed: sets how much simulated time a reading takes, and so how often "
                             "temperatures (re-read when older than 2 s) are scanned")
    parser.add_argument("--profile", action="store_true", help="print the top functions by own time")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        station = yaml.safe_load(DEFAULT_STATION.read_text())
        station["simulated"]["pacing"] = False
        station["simulated"]["real_time_factor"] = 0.0
        (folder / "station.yaml").write_text(yaml.safe_dump(station))
        (folder / "sweep.yaml").write_text(yaml.safe_dump(sweep_yaml(args.points, args.speed)))
        profiler = cProfile.Profile() if args.profile else None
        start = time.perf_counter()
        if profiler:
            profiler.enable()
        result = run_experiment(folder / "sweep.yaml", folder / "station.yaml", folder / "run.h5", progress=False)
        if profiler:
            profiler.disable()
        elapsed = time.perf_counter() - start
        wall = read_run(folder / "run.h5", transcripts=False).column("wall_time_s")
    loop = (wall[-1] - wall[0]) / (len(wall) - 1)
    print(f"status: {result.status}, points: {result.points}, bridge speed: {args.speed}")
    print(f"measuring loop (first to last point): {1 / loop:,.0f} points/s, {loop * 1e6:,.1f} us/point")
    print(f"whole command incl. start-up and close: {result.points / elapsed:,.0f} points/s, "
          f"{elapsed / result.points * 1e6:,.1f} us/point ({elapsed:.2f} s)")
    if profiler:
        pstats.Stats(profiler).sort_stats("tottime").print_stats(25)


if __name__ == "__main__":
    main()
