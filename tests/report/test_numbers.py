"""Numbers in the campaign's report that know their limits (issue 24, points 2, 3, 7): parameter status, no
length from a failing model, the target the report does not diagnose explained, one formatter."""

from __future__ import annotations

import re

import pytest


def _table(html: str, caption_start: str) -> str:
    match = re.search(r"<table[^>]*><caption>" + re.escape(caption_start) + r".*?</table>", html, re.S)
    assert match, caption_start
    return match.group(0)


def _rows(table_html: str) -> dict[str, list[str]]:
    rows = {}
    for row in re.findall(r"<tr>(.*?)</tr>", table_html, re.S):
        cells = [re.sub(r"<[^>]+>", "", c) for c in re.findall(r"<td>(.*?)</td>", row, re.S)]
        if cells:
            rows[cells[0]] = cells
    return rows


def test_steel_parameters_the_data_do_not_determine_are_not_called_fitted(campaign_report):
    steel = _rows(_table(campaign_report.html, "steel target: baseline fit"))
    for name in ("p1", "p3"):
        assert not steel[name][-1].startswith("fitted"), steel[name]
    assert steel["R_p"][-1].startswith("fixed (")
    assert "model fails here" in _table(campaign_report.html, "steel target: baseline fit")


def test_the_steel_target_whose_model_fails_is_diagnosed_like_the_copper_one(campaign_report):
    html = campaign_report.html
    start = html.index("<h3>The steel target</h3>")
    steel = html[start:html.index("</section>", start) if "</section>" in html[start:] else len(html)]
    assert re.search(r"model fails here: the model leaves [0-9.]+ ppm, [0-9]+x the", steel)
    assert 'class="explanation"' in steel
    chain = _rows(_table(steel, "Watch the error fall"))
    assert chain["baseline"][2].startswith("model fails here")  # not the 19,723 mm the diagnosis computes


def test_no_position_error_from_a_failing_model_is_a_length(campaign_report):
    chain = _rows(_table(campaign_report.html, "Watch the error fall"))
    baseline = chain["baseline"]
    rms_ppm = float(baseline[1])
    assert rms_ppm > 500  # the stand-in's baseline leaves far more than the noise
    assert baseline[2].startswith("model fails here") and baseline[3] == "—"


@pytest.mark.parametrize("pattern", [r"0\.0000\d", r"\d 1 \|", r"\d 1<"])
def test_parameters_are_shown_with_si_prefixes_not_long_decimals_or_a_unit_one(campaign_report, pattern):
    tables = "".join(re.findall(r'<table class="params">.*?</table>', campaign_report.html, re.S))
    assert tables and not re.search(pattern, tables.replace("</td>", " |"))


def test_where_the_residual_lives_says_how_far_beyond_chance(campaign_report):
    """Each variable's share of the final residual is shown with how far beyond chance it is, so a share of noise
    does not read as a finding (the caption says so where none is beyond chance)."""
    caption = "Where the final model"
    rows = _rows(_table(campaign_report.html, caption))
    assert rows and all(re.fullmatch(r"[+-][0-9]+\.[0-9]", cells[2]) for cells in rows.values()), rows
    beyond = any(float(cells[2]) > 3.0 for cells in rows.values())
    assert ("none is beyond chance" in _table(campaign_report.html, caption)) is not beyond
