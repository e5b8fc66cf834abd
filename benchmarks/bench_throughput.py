"""End-to-end throughput: drivers, transports, protocol emulators, runner and HDF5 (every point flushed).

Runs a displacement sweep on the simulated lab with instant time and no pacing, and prints
points/s and microseconds per point. Target (issue 3): >= 5,000 points/s.
Usage: python benchmarks/bench_throughput.py [--points N]
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


def sweep_yaml(points: int) -> dict:
    positions = [20.0 + i for i in range(50)]
    readings = max(1, points // (len(positions) * 2))
    return {"kind": "displacement_sweep", "name": "throughput", "home_first": True,
            "sweep": {"positions_mm": positions, "frequencies_hz": [500, 15000], "direction": "forward",
                      "readings_per_point": readings, "settle_s": 0.0}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--points", type=int, default=10_000)
    parser.add_argument("--profile", action="store_true", help="print the top functions by own time")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        station = yaml.safe_load(DEFAULT_STATION.read_text())
        station["simulated"]["pacing"] = False
        station["simulated"]["real_time_factor"] = 0.0
        (folder / "station.yaml").write_text(yaml.safe_dump(station))
        (folder / "sweep.yaml").write_text(yaml.safe_dump(sweep_yaml(args.points)))
        profiler = cProfile.Profile() if args.profile else None
        start = time.perf_counter()
        if profiler:
            profiler.enable()
        result = run_experiment(folder / "sweep.yaml", folder / "station.yaml", folder / "run.h5", progress=False)
        if profiler:
            profiler.disable()
        elapsed = time.perf_counter() - start
    print(f"status: {result.status}, points: {result.points}")
    print(f"end-to-end: {result.points / elapsed:,.0f} points/s, {elapsed / result.points * 1e6:,.1f} us/point "
          f"(wall {elapsed:.2f} s incl. start-up)")
    if profiler:
        pstats.Stats(profiler).sort_stats("tottime").print_stats(25)


if __name__ == "__main__":
    main()
