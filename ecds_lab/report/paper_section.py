"""Report section: the paper's figures of merit against this lab's (``analysis.paper_comparison``)."""

from __future__ import annotations

from ecds_lab.analysis.paper_comparison import RUN_STEMS, Row, compare
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
    runs = {i.path.stem: i.data for i in findings.inputs if i.path.stem in RUN_STEMS}
    rows = compare(runs) if runs else []
    if not rows:
        return [note("the comparison with the paper needs the demo's run files (" + ", ".join(RUN_STEMS) + ")")]
    agreed = sum(r["agrees"] for r in rows)
    cells = [(r["quantity"], str(r["paper"]), _value(r), r["unit"],
              badge("agrees" if r["agrees"] else "differs", "good" if r["agrees"] else "bad"), r["how"])
             for r in rows]
    return [paragraph(f"{agreed} of {len(rows)} quantities agree with Gruber et al. 2024: inside the paper's "
                      "stated bound, or within a factor of 1.5 of an approximate value. Rows that differ say why."),
            table(("quantity", "paper", "ecds-lab", "unit", "", "how"), cells,
                  caption="The paper's results reproduced on this lab", css="paper")]
