"""Diagnosis speed on simulated campaigns of growing size, the whole effect library.

Campaigns are paper campaigns (~1,150 readings each, a hidden effect) joined as recordings of one
campaign, cut to the size asked for. Prints the wall and CPU time of ``run_diagnosis`` per size (CPU
time tells the cost when other work shares the cores), the load average, and the time per 1,000
readings (the cost must grow no faster than linearly). Targets (issue 15):
1,000 readings < 3 s, 100,000 readings < 30 s on this 2-core machine.
Usage: python benchmarks/bench_diagnosis.py [--effect NAME] [--sizes 1000,10000,100000] [--repeat N]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.data.measurements import Measurements
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig


def campaign_of(size: int, effect: str) -> Measurements:
    """Whole paper campaigns (one recording each, different seeds) until ``size`` readings, cut there."""
    effects = {} if effect == "none" else {effect: {"enabled": True}}
    parts, total, seed = [], 0, 11
    while total < size:
        part = campaign.paper_campaign(LabConfig(effects=effects), seed=seed)
        parts.append(part)
        total, seed = total + len(part), seed + 1
    data = Measurements.concatenate(parts)
    return data.select(np.arange(size))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--effect", default="target_bending", help="effect hidden in the campaign ('none' for none)")
    parser.add_argument("--sizes", default="1000,10000,100000")
    parser.add_argument("--repeat", type=int, default=1)
    args = parser.parse_args()
    targets = {1000: 3.0, 100000: 30.0}
    for size in (int(s) for s in args.sizes.split(",")):
        data = campaign_of(size, args.effect)
        times, cpu = [], []
        for _ in range(args.repeat):
            start, start_cpu = time.perf_counter(), time.process_time()
            result = run_diagnosis(data)
            times.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
        best = min(times)
        target = f"  (target < {targets[size]:g} s)" if size in targets else ""
        print(f"diagnose {len(data):>7} readings: {best:6.2f} s wall, {min(cpu):6.2f} s CPU, "
              f"{1000 * best / len(data):.3f} s per 1,000{target}; load average {os.getloadavg()[0]:.1f}; "
              f"verdict {result.verdict}, claimed {result.claimed}, {len(result.outliers)} outliers, "
              f"final {result.final.rmse_ppm:.1f} ppm vs noise {result.noise_ppm:.1f} ppm")


if __name__ == "__main__":
    main()
