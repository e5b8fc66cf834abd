"""The validation study of the diagnosis (issue 23): N campaigns with random truths and designs from the
faithful simulated lab, each diagnosed on a Dask cluster, judged against its truth.

    python benchmarks/validation_study.py --cases 200 --seed 2026 [--workers 2] [--scheduler ADDR] [--json out.json]
    python benchmarks/validation_study.py --cases 40 --scaling 1,2   # wall time against the number of workers
    python benchmarks/validation_study.py --cases 60 --sensors paper,steel,thin_plate   # other plates too

Prints the confident-wrong-claim rate, the false-alarm rate on null truths, the share of revealable
campaigns diagnosed right (or honestly tied), detection per truth and the confusion table
(targets: <= 2 %, <= 5 %, >= 85 %).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from ecds_lab.study import run_study
from ecds_lab.study.cases import draw_cases
from ecds_lab.study.scoring import format_study, rates


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=200)
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--workers", type=int, help="local Dask workers (default: one per core)")
    parser.add_argument("--scheduler", help="a Dask scheduler address instead of a local cluster")
    parser.add_argument("--scaling", help="comma-separated worker counts: time the same cases on each")
    parser.add_argument("--json", type=Path, help="write every case's judgement here")
    parser.add_argument("--sensors", default="paper",
                        help="comma-separated sensors the cases are drawn on (ecds_lab.study.cases.SENSORS; default "
                             "the paper's prototype alone, the study the targets are stated for)")
    args = parser.parse_args()
    sensors = tuple(args.sensors.split(","))
    if args.scaling:
        cases = draw_cases(args.cases, args.seed, sensors)
        for workers in (int(w) for w in args.scaling.split(",")):
            start = time.perf_counter()
            judged = run_study(args.cases, args.seed, workers=workers, cases=cases)
            cpu = sum(j.diagnosis_cpu_s or 0.0 for j in judged)
            print(f"{args.cases} campaigns on {workers} worker(s): {time.perf_counter() - start:.1f} s wall "
                  f"(diagnoses {cpu:.1f} CPU s in all)", flush=True)
        return
    start = time.perf_counter()
    judgements = run_study(args.cases, args.seed, scheduler=args.scheduler, workers=args.workers, sensors=sensors)
    wall = time.perf_counter() - start
    print(format_study(judgements, args.seed))
    print(f"\nwall time {wall:.1f} s ({wall / max(len(judgements), 1):.2f} s per campaign)")
    timed = sorted((j.diagnosis_cpu_s, j.case.number) for j in judgements if j.diagnosis_cpu_s is not None)
    if timed:
        print(f"diagnosis CPU time per campaign: median {timed[len(timed) // 2][0]:.1f} s, "
              f"longest {timed[-1][0]:.1f} s (case {timed[-1][1]})")
    if args.json:
        args.json.write_text(json.dumps({"seed": args.seed, "rates": rates(judgements).to_json(),
                                         "cases": [j.to_json() for j in judgements]}, indent=1))


if __name__ == "__main__":
    main()
