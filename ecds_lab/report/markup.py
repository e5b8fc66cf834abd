"""HTML building blocks of the report: escaped text, tables, notes and figures embedded as base64 PNG.

Everything returned is a string of HTML; every piece of text that comes from data goes
through ``html.escape`` here, so the sections never assemble unescaped markup themselves.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Iterable, Sequence

from ecds_lab.report.canvas import Png


class Html(str):
    """A string that is already HTML (not escaped again)."""


def text(value: object) -> Html:
    """Plain text, escaped."""
    return value if isinstance(value, Html) else Html(html.escape(str(value)))


def paragraph(content: object, css: str = "") -> Html:
    cls = f' class="{css}"' if css else ""
    return Html(f"<p{cls}>{text(content)}</p>")


def note(reason: str) -> Html:
    """The one-line note that stands where a part the data cannot support would be."""
    return Html(f'<p class="omitted"><strong>Omitted:</strong> {text(reason)}</p>')


def heading(level: int, content: object, anchor: str = "") -> Html:
    ident = f' id="{html.escape(anchor)}"' if anchor else ""
    return Html(f"<h{level}{ident}>{text(content)}</h{level}>")


def table(header: Sequence[object], rows: Iterable[Sequence[object]], caption: str = "", css: str = "") -> Html:
    """A table; cells are escaped unless they are ``Html``."""
    cls = f' class="{css}"' if css else ""
    parts = [f"<table{cls}>"]
    if caption:
        parts.append(f"<caption>{text(caption)}</caption>")
    parts.append("<thead><tr>" + "".join(f"<th>{text(h)}</th>" for h in header) + "</tr></thead><tbody>")
    for row in rows:
        parts.append("<tr>" + "".join(f"<td>{text(c)}</td>" for c in row) + "</tr>")
    parts.append("</tbody></table>")
    return Html("".join(parts))


def lines(items: Iterable[object]) -> Html:
    """Several lines in one cell."""
    return Html("<br>".join(text(i) for i in items))


def figure(png: Png, caption: str) -> Html:
    """The PNG embedded in the page (data URI), with its size and a caption (none: the next figure continues it)."""
    data = base64.b64encode(png.data).decode("ascii")
    below = f"<figcaption>{text(caption)}</figcaption>" if caption else ""
    css = "" if caption else ' class="continued"'
    return Html(f'<figure{css}><img src="data:image/png;base64,{data}" width="{png.width}" height="{png.height}" '
                f'alt="{html.escape(png.alt)}">{below}</figure>')


def side_by_side(*blocks: Html) -> Html:
    return Html('<div class="side-by-side">' + "".join(f"<div>{b}</div>" for b in blocks) + "</div>")


def number(value: float | None, digits: int = 3, unit: str = "") -> str:
    """A number with ``digits`` significant digits (and a unit), or an em dash when unknown."""
    if value is None or not math.isfinite(value):
        return "—"
    return f"{value:.{digits}g}" + (f" {unit}" if unit else "")


def value_error(value: float, stderr: float | None, scale: float = 1.0, unit: str = "") -> str:
    """value ± standard error in a given scale (the unit in a table's header), by ``quantities.format_quantity``:
    the error's two significant digits set the precision, as everywhere else."""
    from ecds_lab.analysis.quantities import format_quantity

    error = None if stderr is None or not math.isfinite(stderr) or stderr <= 0 else stderr * abs(scale)
    shown = format_quantity(value * scale, "", error)
    return f"{shown} {unit}" if unit else shown


def badge(content: str, css: str) -> Html:
    return Html(f'<span class="badge {html.escape(css)}">{text(content)}</span>')


def quantity_span(key: str, value: float | None, unit: str = "", text_shown: str | None = None) -> Html:
    """A reported quantity, shown with ``quantities.format_quantity`` and marked with its key and SI value
    (``data-q``, ``data-v``), so every place that shows one quantity can be checked to show one value."""
    from ecds_lab.analysis.quantities import format_quantity

    shown = text_shown if text_shown is not None else format_quantity(value, unit)
    raw = "" if value is None or not math.isfinite(value) else f"{value:.6g}"
    return Html(f'<span data-q="{html.escape(key)}" data-v="{raw}">{text(shown)}</span>')
