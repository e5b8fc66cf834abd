"""Benchmark: time the baseline fit on a ~1,000-point simulated paper campaign and on a large one.

Run: ``python benchmarks/bench_fit.py [--seed N] [--repeat N] [--size N]``. Not a timed test;
targets (issue 15): a 1,000-point fit well under 2 s, a 100,000-point fit under 5 s on this
2-core machine. The large campaign is paper campaigns (different seeds) joined as recordings.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from ecds_lab.analysis.fitting import fit
from ecds_lab.analysis.summary import fit_summary
from ecds_lab.data.measurements import Measurements
from ecds_lab.simulators.campaign import paper_campaign
from ecds_lab.simulators.config import LabConfig


def truth(config: LabConfig) -> dict[str, float]:
    """The simulated lab's parameters in the model's names."""
    sensor = config.sensor
    return {"L0": sensor.inductance_h, "alpha": config.alpha, "beta": config.beta_per_k2, "tau_t": config.tau_t,
            "p1": 0.0, "p2": 1.0, "p3": 1.0, "p4": 0.0, "C_p": sensor.capacitance_f}


def main() -> None:
    """Time campaign generation, the fit and the full summary; print recovered vs simulated values."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeat", type=int, default=5, help="fits to time")
    parser.add_argument("--size", type=int, default=100_000, help="readings of the large campaign (0: skip)")
    args = parser.parse_args()
    config = LabConfig()
    began = time.perf_counter()
    data = paper_campaign(config, seed=args.seed)
    campaign_s = time.perf_counter() - began
    times = []
    for _ in range(args.repeat):
        began = time.perf_counter()
        result = fit(data)
        times.append(time.perf_counter() - began)
    began = time.perf_counter()
    fit_summary(data)
    summary_s = time.perf_counter() - began
    print(f"campaign: {len(data)} readings in {campaign_s:.3f} s")
    print(f"fit: median {statistics.median(times):.3f} s, min {min(times):.3f} s over {args.repeat} "
          f"({result.nfev} evaluations, {result.starts} start(s))")
    print(f"fit summary (fit + calibrations + position errors): {summary_s:.3f} s")
    print(f"residual RMS {result.rms_ppm:.2f} ppm (simulated bridge noise "
          f"{config.noise.bridge_relative['slow'] * 1e6:.0f} ppm), dof {result.dof}, BIC {result.bic:.1f}")
    print(f"{'param':<7} {'fitted':>14} {'stderr':>11} {'simulated':>14} {'z':>6}")
    for name, value in truth(config).items():
        fitted, err = result.values[name], result.stderr[name]
        print(f"{name:<7} {fitted:>14.7g} {err:>11.3g} {value:>14.7g} {(fitted - value) / err:>6.2f}")
    if args.size:
        large = large_campaign(config, args.size)
        began = time.perf_counter()
        big = fit(large)
        print(f"fit of {len(large)} readings: {time.perf_counter() - began:.2f} s (target < 5 s; "
              f"{big.nfev} evaluations, {big.starts} start(s), RMS {big.rms_ppm:.2f} ppm)")


def large_campaign(config: LabConfig, size: int) -> Measurements:
    """Paper campaigns with different seeds, joined as recordings of one campaign, cut to ``size``."""
    parts, total, seed = [], 0, 100
    while total < size:
        parts.append(paper_campaign(config, seed=seed))
        total, seed = total + len(parts[-1]), seed + 1
    return Measurements.concatenate(parts).select(np.arange(size))


if __name__ == "__main__":
    main()
