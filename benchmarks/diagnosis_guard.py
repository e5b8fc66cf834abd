"""Same conclusion, faster: compare what `ecds-lab diagnose --json` concludes before and after a speed change.

A speed change to the diagnosis (reused fits, warm starts, screening) must not change what it concludes on the
benchmark campaigns (``benchmarks/bench_cli.py``'s cached faithful-lab inputs). This script reduces a diagnosis's
JSON to its conclusion (verdict, claimed effects, the chain of effects added, alternatives, partial and undetermined
groups, untestable effects, the glitches excluded and the final RMSE) and compares two of them: every name must
match, and the final RMSE and the noise agree within ``--rtol`` (relative; default 1e-3).

Usage:
  python benchmarks/diagnosis_guard.py record DIAGNOSIS.json... -o BASELINE.json   (conclusions of a reference run)
  python benchmarks/diagnosis_guard.py compare BASELINE.json DIAGNOSIS.json... [--rtol 1e-3]
A DIAGNOSIS.json is the output of ``ecds-lab diagnose DATA --json > DIAGNOSIS.json``; its file name (not its
directory) is the key, so name each after its campaign (``field-100000.json``). Exit 1 when a conclusion changed.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

#: The conclusion's names: each must be equal before and after.
EXACT = ("verdict", "claimed", "chain", "alternatives", "partial", "undetermined", "untestable", "outliers")
#: The conclusion's figures: each within the relative tolerance.
CLOSE = ("final_rmse_ppm", "baseline_rmse_ppm", "noise_ppm")


def conclusion(diagnosis: dict[str, Any]) -> dict[str, Any]:
    """What a diagnosis (its JSON) concludes, as plain comparable values."""
    steps = diagnosis["steps"]
    return {"verdict": diagnosis["verdict"], "claimed": list(diagnosis["claimed"]),
            "chain": [step["effects"] for step in steps],
            "alternatives": sorted(sorted(g) for g in diagnosis["alternatives"]),
            "partial": sorted(sorted(g) for g in diagnosis["partial"]),
            "undetermined": sorted(diagnosis["undetermined"]),
            "untestable": sorted(diagnosis["untestable"]),
            "outliers": sorted(o["row"] for o in diagnosis["outliers"]),
            "final_rmse_ppm": steps[-1]["rmse_ppm"], "baseline_rmse_ppm": diagnosis["baseline"]["rmse_ppm"],
            "noise_ppm": diagnosis["noise_ppm"]}


def differences(before: dict[str, Any], after: dict[str, Any], rtol: float) -> list[str]:
    """Each way ``after`` concludes otherwise than ``before`` (empty: the same conclusion)."""
    out = [f"{key}: {before[key]!r} -> {after[key]!r}" for key in EXACT if before[key] != after[key]]
    out += [f"{key}: {before[key]} -> {after[key]} (beyond rtol {rtol:g})" for key in CLOSE
            if not math.isclose(before[key], after[key], rel_tol=rtol)]
    return out


def _read(paths: list[Path]) -> dict[str, dict[str, Any]]:
    return {path.name: conclusion(json.loads(path.read_text())) for path in paths}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    record = sub.add_parser("record")
    record.add_argument("diagnoses", nargs="+", type=Path)
    record.add_argument("-o", "--output", type=Path, required=True)
    compare = sub.add_parser("compare")
    compare.add_argument("baseline", type=Path)
    compare.add_argument("diagnoses", nargs="+", type=Path)
    compare.add_argument("--rtol", type=float, default=1e-3)
    args = parser.parse_args(argv)
    if args.command == "record":
        args.output.write_text(json.dumps(_read(args.diagnoses), indent=2) + "\n")
        print(f"{len(args.diagnoses)} conclusion(s) -> {args.output}")
        return 0
    baseline = json.loads(args.baseline.read_text())
    changed = 0
    for name, after in _read(args.diagnoses).items():
        if name not in baseline:
            print(f"{name}: no baseline recorded")
            changed += 1
            continue
        found = differences(baseline[name], after, args.rtol)
        changed += bool(found)
        print(f"{name}: " + ("same conclusion" if not found else "CHANGED\n  " + "\n  ".join(found)))
        print(f"  verdict {after['verdict']}, claimed {after['claimed']}, final rmse {baseline[name]['final_rmse_ppm']}"
              f" -> {after['final_rmse_ppm']} ppm")
    return 1 if changed else 0


if __name__ == "__main__":
    sys.exit(main())
