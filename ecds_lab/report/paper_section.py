"""Report section: the paper's figures of merit against this lab's (``analysis.paper_comparison``)."""

from __future__ import annotations

from ecds_lab.analysis.paper_comparison import ROLES, Row, compare, runs_by_role
from ecds_lab.report.findings import Findings
from ecds_lab.report.markup import Html, badge, note, paragraph, table
from ecds_lab.report.render import Plot


def _value(row: Row) -> str:
    value = row["ecds_lab"]
    if isinstance(value, list):
        return " … ".join(f"{v:g}" for v in value)
    return "—" if value is None else f"{value:g}"


def paper_comparison_section(findings: Findings) -> list[Html | Plot]:
    """The table the demo writes to paper_comparison.json, one row per quantity."""
    runs = runs_by_role([i.file for i in findings.inputs])
    rows = compare(runs) if runs else []
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
