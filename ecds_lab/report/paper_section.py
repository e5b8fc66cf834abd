"""Report section: the paper's figures of merit against this lab's (``analysis.paper_comparison``)."""

from __future__ import annotations

from typing import Any

from ecds_lab.analysis.paper_comparison import ROLES, Row, compare, copper_calibrations, role_of, runs_by_role
from ecds_lab.data.measurements import Measurements
from ecds_lab.report.findings import Findings
from ecds_lab.report.markup import Html, badge, note, paragraph, table
from ecds_lab.report.render import Plot
from ecds_lab.storage.data_file import DataFile


def _value(row: Row) -> str:
    value = row["ecds_lab"]
    if isinstance(value, list):
        return " … ".join(f"{v:g}" for v in value)
    return "—" if value is None else f"{value:g}"


def _table_calibrations(findings: Findings, files: list[DataFile], runs: dict[str, Measurements]) -> list[Any]:
    """The position table's copper calibrations at 15 kHz for the n = 4 row: the main group's when the report
    made them, else the same ``copper_calibrations`` the demo's paper_comparison.json uses."""
    main = getattr(findings, "main", None)
    if main is not None and main.material == "copper" and 15000.0 in main.cases:
        return list(main.cases[15000.0])
    sweep = next((f for f in files if role_of(f) == "displacement_sweep"), None)
    return copper_calibrations(runs, sweep.sensor if sweep is not None else None)


def paper_comparison_section(findings: Findings) -> list[Html | Plot]:
    """The table the demo writes to paper_comparison.json, one row per quantity."""
    files = [i.file for i in findings.inputs]
    runs = runs_by_role(files)
    rows = compare(runs, _table_calibrations(findings, files, runs)) if runs else []
    if not rows:
        needed = ", ".join(f"{kind}" + (f" ({target} target)" if target else "") for kind, target in ROLES.values())
        return [note("the comparison with the paper needs recordings of the paper's experiments at 500 Hz and "
                     f"15 kHz (by experiment kind: {needed})")]
    agreed = sum(r["agrees"] for r in rows)
    cells = [(r["quantity"], str(r["paper"]), _value(r), r["unit"],
              badge("agrees" if r["agrees"] else "differs", "good" if r["agrees"] else "bad"), r["how"])
             for r in rows]
    return [paragraph(f"{agreed} of {len(rows)} quantities agree with Gruber et al. 2024: inside the paper's "
                      "stated bound, or within a factor of 1.5 of an approximate value. Rows that differ say what "
                      "these data show. Each quantity is computed by the paper's own procedure, named in its row: "
                      "position errors as ΔL / S (Sec. 3.3, 4.3) with Eq. (4) fitted per frequency to the steady "
                      "coil temperatures in air; the position table above inverts a calibration (Sec. 5) instead."),
            table(("quantity", "paper", "ecds-lab", "unit", "", "how"), cells,
                  caption="The paper's results reproduced on this lab", css="paper")]
