"""One number per quantity (issue 24, point 1): every quantity the demo's report, fit JSON and paper comparison
show in more than one place has one value there, and every place quotes one full scale."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from ecds_lab.analysis.paper_comparison import paper_comparison
from ecds_lab.analysis.summary import fit_summary
from ecds_lab.data.measurements import Measurements
from ecds_lab.storage.data_file import open_data


@pytest.fixture(scope="module")
def outputs(campaign_files: list[Path], campaign_report):
    """What the demo writes: the fit JSON of the copper campaign, paper_comparison.json and the report."""
    copper = [p for p in campaign_files if open_data(p).sensor.target == "copper"
              and "spectroscopy" not in (open_data(p).run.kind if open_data(p).run else "")]
    fit = json.loads(json.dumps(fit_summary(Measurements.concatenate([open_data(p).data for p in copper]), [])))
    rows = json.loads(json.dumps(paper_comparison(campaign_files)))
    return fit, rows, campaign_report.html


def _places(fit: dict, rows: list[dict], html: str) -> dict[str, list[tuple[str, float]]]:
    """key -> [(where, value)] over the fit JSON's quantities, the paper rows' quantities and the report's marks."""
    places: dict[str, list[tuple[str, float]]] = {}
    for key, value in fit["quantities"].items():
        if value is not None:
            places.setdefault(key, []).append(("fit.json", float(value)))
    for row in rows:
        for key, value in row.get("quantities", {}).items():
            places.setdefault(key, []).append((f"paper_comparison.json: {row['quantity']}", float(value)))
    for key, value in re.findall(r'data-q="([^"]+)" data-v="([^"]*)"', html):
        if value:
            places.setdefault(key, []).append(("report.html", float(value)))
    return places


def test_every_quantity_shown_in_several_places_has_one_value(outputs):
    fit, rows, html = outputs
    places = _places(fit, rows, html)
    shared = {key: where for key, where in places.items() if len({w for w, _ in where}) > 1}
    # the coil's Eq. (4) and the coil-heated position errors are each shown in two outputs
    assert any(key.startswith("eq4.alpha_per_k.500Hz") for key in shared), sorted(places)
    assert any(".coil_compensated." in key for key in shared), sorted(places)
    assert any(key.startswith("ts_ppm_fs_per_k.coil_compensated.") for key in shared), sorted(places)
    for key, where in shared.items():
        values = [v for _, v in where]
        assert max(values) - min(values) <= 1e-5 * max(abs(v) for v in values), (key, where)


def test_one_full_scale_everywhere(outputs):
    fit, rows, html = outputs
    fs = {c[label]["fs_mm"] for c in fit["calibration"] for label in ("all_points", "n4")}
    assert len(fs) == 1
    quoted = {float(v) for v in re.findall(r"FS = ([0-9.]+) mm", html + json.dumps(rows, ensure_ascii=False))}
    assert quoted == fs


def test_the_coil_compensation_is_the_papers_and_better_than_none_in_every_output(outputs):
    fit, rows, html = outputs
    at_500 = next(c for c in fit["calibration"] if c["freq_hz"] == 500.0)["all_points"]["coil_heated"]
    assert "steady" in at_500["compensation_method"]
    assert at_500["compensated"]["max_abs_mm"] < 0.5 * at_500["uncompensated"]["max_abs_mm"]
    alpha = fit["quantities"]["eq4.alpha_per_k.500Hz"]
    assert 0 < alpha * 1e6 < 30  # the coil expands: L grows with temperature at 500 Hz
    assert "joint model fit" in html and "model fails here" in html
    coil = [r for r in rows if r["quantity"].startswith("coil heated")]
    assert coil and all("steady coil temperatures" in r["how"] for r in coil[:1])
