"""``ecds-lab report``: one self-contained HTML file (figures embedded as PNG, no scripts, no links out).

The page can be opened from disk or sent by mail: styles are inline, every figure is a
``data:`` URI, and nothing is fetched.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from ecds_lab import __version__
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.report import render
from ecds_lab.report.canvas import Png
from ecds_lab.report.findings import diagnose, find
from ecds_lab.report.inputs import load_inputs
from ecds_lab.report.investigation import ANCHOR, TITLE, find_investigation, investigation_section, load_investigation
from ecds_lab.report.markup import Html, figure, heading, text
from ecds_lab.report.render import Plot
from ecds_lab.report.sections import DIAGNOSIS, Section, anchors, build_sections

log = logging.getLogger("ecds_lab.report")

CSS = """
:root { color-scheme: light; }
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; color: #1d2330;
       margin: 0; background: #f4f5f7; }
header { background: #1f3b5a; color: #fff; padding: 1.2rem 2rem; }
header h1 { margin: 0 0 .3rem; font-size: 1.6rem; }
header p { margin: .2rem 0; color: #d8e2ee; }
nav ol { margin: .6rem 0 0; padding-left: 1.2rem; columns: 2; }
nav a { color: #fff; }
main { max-width: 1440px; margin: 0 auto; padding: 1rem 2rem 3rem; }
section { background: #fff; border-radius: 6px; box-shadow: 0 1px 3px rgba(0,0,0,.08); margin: 1.2rem 0;
          padding: .4rem 1.4rem 1.2rem; }
h2 { border-bottom: 2px solid #1f3b5a; padding-bottom: .2rem; }
figure { margin: 1rem 0; }
figure.continued { margin-bottom: 0; }
figure.continued + figure { margin-top: 0; }
figure img { max-width: 100%; height: auto; display: block; border: 1px solid #e3e6ea; }
figcaption { font-size: .88rem; color: #4a5363; margin-top: .3rem; max-width: 70rem; }
table { border-collapse: collapse; margin: .6rem 0; font-size: .86rem; }
caption { text-align: left; font-weight: 600; padding: .2rem 0; }
th, td { border: 1px solid #d9dde3; padding: .25rem .5rem; vertical-align: top; text-align: left; }
th { background: #eef1f5; }
table.runs td { max-width: 22rem; overflow-wrap: anywhere; }
table.ts { font-size: .8rem; }
.side-by-side { display: flex; flex-wrap: wrap; gap: 1.5rem; align-items: flex-start; }
@media (min-width: 1200px) { .side-by-side { flex-wrap: nowrap; } }
.tables { display: flex; flex-wrap: wrap; gap: 1.5rem; align-items: flex-start; }
.omitted { color: #6b5b00; background: #fff8db; border-left: 4px solid #e0b000; padding: .4rem .7rem; }
.explanation { font-size: 1.02rem; background: #f2f7fd; border-left: 4px solid #1f6fb2; padding: .5rem .8rem; }
.badge { display: inline-block; white-space: nowrap; padding: .05rem .55rem; border-radius: .8rem;
         font-weight: 600; font-size: .85rem; }
.badge.good { background: #d7f2dd; color: #145c26; }
.badge.bad { background: #fbdcdc; color: #8a1c1c; }
.small { font-size: .85rem; color: #4a5363; }
"""


def write_report(data_paths: Sequence[Path], output: Path, *, diagnosis: Any = None,
                 workers: int | None = None, effects: EffectRegistry | None = None,
                 investigation: Path | None = None) -> Path:
    """Write the HTML report of the data files (run files or CSV) to ``output``; returns its path.

    ``diagnosis``: a ``Diagnosis`` (``ecds_lab.analysis.diagnosis.run_diagnosis``) of the main
    target group's readings, to show instead of running one. ``workers``: processes drawing the
    figures (default: one per CPU, less one while the diagnosis runs, so one on two CPUs; 1 given draws in this
    process).
    ``effects``: the ``EffectRegistry`` the diagnosis searches (default: the library and installed packages').
    ``investigation``: an ``investigate.json`` for the chapter "How the question was decided" (default: one found
    in the folder of a data file, if any).
    """
    began = time.perf_counter()
    paths = [Path(p) for p in data_paths]
    if not paths:
        raise ValueError("write_report needs at least one data file")
    findings = find(load_inputs(paths))
    analysed = time.perf_counter()
    sections = build_sections(findings, [a for a in anchors() if a != DIAGNOSIS])
    plots = [plot for section in sections for plot in section.plots()]
    running_diagnosis = diagnosis is None and findings.main is not None
    # While the diagnosis runs here, the other figures are drawn by the other CPUs (on two, by one forked worker)
    with render.start(plots, render.default_workers(busy=1 if running_diagnosis else 0) if workers is None else workers,
                      alongside=running_diagnosis and workers is None and render.cpus() > 1) as rendering:
        diagnose(findings, diagnosis, effects)
        diagnosed = time.perf_counter()
        (diagnosis_section,) = build_sections(findings, [DIAGNOSIS])
        late = diagnosis_section.plots()  # drawn now by every CPU: the other figures were drawn beside the diagnosis
        with render.start(late, workers) as late_rendering:
            drawn = dict(zip(map(id, late), late_rendering.results(), strict=True))
        drawn.update(zip(map(id, plots), rendering.results(), strict=True))
    sections.insert(anchors().index(DIAGNOSIS), diagnosis_section)
    record = investigation if investigation is not None else find_investigation(paths)
    if record is not None:
        sections.insert(anchors().index(DIAGNOSIS) + 1,
                        Section(ANCHOR, TITLE, list(investigation_section(load_investigation(record)))))
    page = document(sections, [p.name for p in paths], drawn)
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(page, encoding="utf-8")
    log.info("report of %d file(s) -> %s in %.1f s (analysis %.1f s, diagnosis %.1f s, figures and page %.1f s)",
             len(paths), output, time.perf_counter() - began, analysed - began, diagnosed - analysed,
             time.perf_counter() - diagnosed)
    return output


def document(sections: list[Section], sources: list[str], drawn: dict[int, Png]) -> str:
    """The whole page; ``drawn`` maps id(plot) to its PNG for every figure of the sections."""
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    title = "ECDS lab report: " + ", ".join(sources)
    contents = "".join(f'<li><a href="#{s.anchor}">{text(s.title)}</a></li>' for s in sections)
    body = "".join(f"<section>{heading(2, s.title, s.anchor)}"
                   + "".join(figure(drawn[id(part)], part.caption) if isinstance(part, Plot) else part
                             for part in s.body)
                   + "</section>" for s in sections)
    return Html(
        "<!DOCTYPE html>\n"
        '<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1"><link rel="icon" href="data:,">'
        f"<title>{text(title)}</title><style>{CSS}</style></head><body>"
        f"<header><h1>Eddy current displacement sensor: lab report</h1>"
        f"<p>{text(', '.join(sources))}</p>"
        f"<p>written {stamp} by ecds-lab {text(__version__)}</p>"
        f"<nav><ol>{contents}</ol></nav></header>"
        f"<main>{body}</main></body></html>\n"
    )
