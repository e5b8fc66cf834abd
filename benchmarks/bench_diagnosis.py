"""Diagnosis speed: a ~1,000-point paper campaign with a hidden effect, the whole effect library.

Prints the wall time of ``run_diagnosis`` (baseline fit, every library candidate with its
alternative starts, grouped cross-validation of the leading candidates, and the follow-up round
after adding the best effect). Target (issue 6): under 20 s on this 2-core machine.
Usage: python benchmarks/bench_diagnosis.py [--effect NAME] [--repeat N]
"""

from __future__ import annotations

import argparse
import time

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--effect", default="target_bending", help="effect hidden in the campaign ('none' for none)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    effects = {} if args.effect == "none" else {args.effect: {"enabled": True}}
    data = campaign.paper_campaign(LabConfig(effects=effects), seed=11)
    times = []
    for _ in range(args.repeat):
        start = time.perf_counter()
        result = run_diagnosis(data)
        times.append(time.perf_counter() - start)
    print(f"campaign: {len(data)} readings, hidden effect: {args.effect}")
    print(f"diagnosis: median {sorted(times)[len(times) // 2]:.2f} s, min {min(times):.2f} s over {len(times)} "
          f"(verdict {result.verdict}, best {result.best.effect if result.best else '-'}, "
          f"{len(result.candidates)} candidates)")


if __name__ == "__main__":
    main()
