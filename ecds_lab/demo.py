"""``ecds-lab demo``: the paper's whole campaign on the simulated lab, then analysis and report."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

from ecds_lab import shipped
from ecds_lab.runner.session import RunResult, run_experiment

#: (experiment, station) pairs of the campaign, in the order the paper presents them.
CAMPAIGN: tuple[tuple[str, str], ...] = (
    ("displacement_sweep.yaml", "simulated_lab.yaml"),
    ("coil_heating.yaml", "simulated_lab_in_air.yaml"),
    ("spectroscopy.yaml", "simulated_lab_in_air.yaml"),
    ("target_heating_copper.yaml", "simulated_lab.yaml"),
    ("target_heating_steel.yaml", "simulated_lab_steel.yaml"),
)

log = logging.getLogger("ecds_lab.demo")


def run_demo(output: Path, progress: bool = True) -> list[RunResult]:
    """Run every shipped experiment into ``output``, then fit, diagnose and report where possible."""
    output.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    results = []
    for experiment, station in CAMPAIGN:
        run_file = output / experiment.replace(".yaml", ".h5")
        result = run_experiment(shipped.experiment(experiment), shipped.station(station), run_file,
                                overwrite=True, progress=progress)
        print(f"{result.status:9s} {result.points:5d} rows  {run_file}  ({result.wall_s:.1f} s)")
        results.append(result)
    analyse_campaign([r.path for r in results], output)
    print(f"demo finished in {time.monotonic() - started:.1f} s; open {output / 'report.html'}")
    return results


def analyse_campaign(run_files: list[Path], output: Path) -> None:
    """Compare with the paper, fit and diagnose the copper campaign, then write the HTML report."""
    from ecds_lab.analysis.diagnosis import format_diagnosis, run_diagnosis
    from ecds_lab.analysis.paper_comparison import paper_comparison
    from ecds_lab.analysis.summary import fit_summary
    from ecds_lab.data.measurements import Measurements
    from ecds_lab.report.html import write_report
    from ecds_lab.storage.data_file import open_data

    rows = paper_comparison(run_files)
    (output / "paper_comparison.json").write_text(json.dumps(rows, indent=2, ensure_ascii=False))
    print(f"paper comparison: {sum(r['agrees'] for r in rows)} of {len(rows)} quantities agree "
          f"({output / 'paper_comparison.json'})")

    # The copper campaign: every recording with the copper target or the coil in air, spectroscopy aside;
    # chosen by what each file holds (its run kind and sensor), not by its name.
    opened = [open_data(p) for p in run_files]
    copper = [f.data for f in opened if f.sensor.target == "copper" and (f.run is None or f.run.kind != "spectroscopy")]
    data = Measurements.concatenate(copper)
    fit = fit_summary(data, [])
    (output / "fit.json").write_text(json.dumps(fit, indent=2))
    diagnosis = run_diagnosis(data)
    report = diagnosis.to_json()
    (output / "diagnosis.json").write_text(json.dumps(report, indent=2))
    print(format_diagnosis(report))
    write_report(run_files, output / "report.html", diagnosis=diagnosis)
