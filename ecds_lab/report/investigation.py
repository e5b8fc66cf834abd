"""The report's chapter "How the question was decided": the rounds of an ``ecds-lab investigate`` loop, read from
its ``investigate.json`` (docs/planning.md), given to ``report --investigation`` or found beside the data files.

Per round: the competing models, the experiment chosen with its predicted separation, the separation measured once
it was run, and the verdict after it. The chapter reads the JSON only; it recomputes nothing.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ecds_lab.report.markup import Html, lines, note, paragraph, table

ANCHOR, TITLE = "decided", "How the question was decided"
FILE_NAME = "investigate.json"


def find_investigation(paths: Sequence[Path]) -> Path | None:
    """An ``investigate.json`` in the folder of one of the data files (the loop writes its runs beside it)."""
    for path in paths:
        candidate = Path(path).parent / FILE_NAME
        if candidate.is_file():
            return candidate
    return None


def load_investigation(path: Path) -> dict[str, Any]:
    """The loop's record; a file that is not one raises ValueError naming it."""
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as error:
        raise ValueError(f"{path}: not a readable investigate.json ({error})") from None
    if not isinstance(record, dict) or not isinstance(record.get("rounds"), list):
        raise ValueError(f"{path}: not an investigate.json (no 'rounds' list)")
    return record


def _models(entry: dict[str, Any]) -> Html:
    questions = [f"{q.get('kind')}: {', '.join(q.get('effects', [])) or q.get('text', '')}"
                 for q in entry.get("open_questions", [])]
    return lines(questions or ["none"])


def _chosen(entry: dict[str, Any]) -> str:
    chosen = entry.get("chosen")
    if not chosen:
        return "nothing: " + str(entry.get("why", ""))
    return f"{chosen.get('what')} ({float(chosen.get('hours', 0.0)):.2f} h)"


def _number(value: Any) -> str:
    return "—" if value is None else f"{float(value):.1f}"


def _after(entry: dict[str, Any]) -> str:
    after = entry.get("diagnosis_after")
    if not after:
        if entry.get("run_file") is None:
            return "not run" if entry.get("chosen") else "—"
        return f"run {entry.get('run_status', '?')}"
    claimed = ", ".join(after.get("claimed", [])) or "nothing claimed"
    tied = "; tied: " + " | ".join(" / ".join(g) for g in after.get("alternatives", [])) if after.get(
        "alternatives") else ""
    return f"{after.get('verdict')}: {claimed}{tied}"


def investigation_section(record: dict[str, Any]) -> list[Html]:
    """The chapter's HTML: one row per round, then why the loop stopped and the final verdict."""
    rows = []
    for entry in record["rounds"]:
        measured = entry.get("measured") or {}
        won = f" ({measured['winner']} fits best)" if measured.get("winner") else ""
        rows.append((entry.get("round", ""), _models(entry), _chosen(entry), _number(entry.get("predicted_delta_chi2")),
                     _number(entry.get("measured_delta_chi2")) + won, _after(entry)))
    final = record.get("final") or {}
    parts = [paragraph("Each round: the open questions of the diagnosis, the experiment that separates their models "
                       "best per hour of lab time (predicted Delta chi-square, noise variances; 25 decides), the "
                       "separation measured once it ran, and the verdict after it.", "small"),
             table(("round", "open questions", "chosen experiment", "predicted Δχ²", "measured Δχ²", "verdict after"),
                   rows, css="runs")]
    parts.append(paragraph(f"The loop stopped: {record.get('stopped') or 'not recorded'}. "
                           f"Final verdict: {final.get('verdict', 'unknown')}; claimed: "
                           f"{', '.join(final.get('claimed', [])) or 'nothing'}; lab time spent: "
                           f"{float(record.get('hours_spent', 0.0)):.2f} h."))
    if not record["rounds"]:
        parts = [note("the investigation recorded no round")]
    return parts
