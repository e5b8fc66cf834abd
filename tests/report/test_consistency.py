"""One number per quantity (issue 24, point 1): every quantity the demo's report, fit JSON and paper comparison
show in more than one place has one value there, and every place quotes one full scale."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
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
    # the n = 4 vs all-points row quotes the position table's calibrations, not calibrations of its own
    assert {"position_error.rms_mm.room.copper.15000Hz.all_points",
            "position_error.rms_mm.room.copper.15000Hz.n4"} <= set(shared), sorted(places)
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


def _section(html: str, anchor: str) -> str:
    start = html.index(f'<h2 id="{anchor}">')
    end = html.find("<section>", start)
    return html[start:end if end > 0 else len(html)]


def test_the_steel_diagnosis_line_quotes_one_residual_and_one_noise(campaign_report):
    """The other target's verdict line gave the diagnosis' baseline residual and, in the same sentence, "model
    fails here" with the figures of the model-fit section's fit (7534.6 ppm and then 7562 ppm, noise 148.9 and
    then 149 of 148.7): the line now judges the diagnosis' own model on its own noise."""
    diagnosis = _section(campaign_report.html, "diagnosis")
    line = diagnosis[diagnosis.index("<h3>The steel target</h3>"):]
    line = line[:line.index("</p>")]
    residual = float(re.search(r"baseline residual ([0-9.]+) ppm of L", line).group(1))
    noise = float(re.search(r"noise ([0-9.]+) ppm \(", line).group(1))
    leaves = re.search(r"the model leaves ([0-9.]+) ppm, [0-9.]+x the ([0-9.]+) ppm noise", line)
    assert leaves, line  # the demo's steel model fails; the line says so
    assert float(leaves.group(1)) == pytest.approx(residual, abs=0.5)
    assert float(leaves.group(2)) == pytest.approx(noise, rel=5e-3)


def test_the_diagnosis_says_why_its_baseline_residual_differs_from_the_model_fit_section(campaign_report):
    """Both sections fit the baseline to the steel readings; the diagnosis leaves a glitch out, so its residual
    (7534.6 ppm) differs from the fit section's (7562.1 ppm). The diagnosis line names the glitches and quotes the
    other figure, so the two do not disagree without a word."""
    html = campaign_report.html
    diagnosis = _section(html, "diagnosis")
    steel = diagnosis[diagnosis.index("<h3>The steel target</h3>"):]
    line = steel[:steel.index("</p>")]
    explanation = steel[:steel.index("</p>", len(line) + 4)]
    fit_residual = re.search(r"steel target: baseline fit of [0-9]+ readings, residual RMS ([0-9.]+) ppm",
                             _section(html, "fit")).group(1)
    glitches = re.search(r"([0-9]+) glitch reading\(s\) were excluded", explanation)
    residual = re.search(r"baseline residual ([0-9.]+) ppm of L", line).group(1)
    if glitches:
        assert (f"{glitches.group(1)} glitch reading(s) left out: the model fit section's baseline fit, which takes "
                f"every reading, leaves {fit_residual} ppm with them") in line, line
    else:
        assert residual == fit_residual, (residual, fit_residual)


def test_the_chain_position_error_counts_no_coil_in_air_reading_as_out_of_range():
    """A coil-in-air reading has no position: the chain's figure is the step's own (the diagnosis JSON's),
    not "325 of 729 readings out of range" as the report's own count made it."""
    from types import SimpleNamespace

    from ecds_lab.analysis.diagnosis import Step
    from ecds_lab.report.sections import step_error

    residual_mm = np.array([0.02, -0.03, np.nan, np.nan, 0.01, np.nan])
    step = Step([], SimpleNamespace(rms_ppm=30.0), residual_mm, 80.0)
    figure = step_error(step, 30.0)
    assert figure.n_out_of_range == 0 and figure.n == 3
    assert figure.to_json() == step.position_error(30.0).to_json()
    assert "out of range" not in figure.text("rms")


def test_a_target_rise_the_paper_rows_quote_is_the_tables_or_is_named_as_another(outputs, campaign_report):
    """The position table gives the copper plate's largest rise (108 K); the paper rows quoted '107 K' for the same
    heating without saying it is the mean of the hot sweep over the room sweep. Each paper row quoting a target rise
    either quotes the table's figure or names its own."""
    _, rows, _ = outputs
    position = _section(campaign_report.html, "position")
    table_rise = {material: int(rise) for material, rise in
                  re.findall(r"<td>target heated<br>(\w+) target, [0-9]+ Hz</td><td>([0-9]+) K</td>", position)}
    assert "copper" in table_rise
    quoted = [(r["quantity"], int(m.group(1))) for r in rows
              if (m := re.search(r"(?:copper )?target[^,]*?(?:heated|ΔT)[^0-9,]*([0-9]+) K", r["quantity"]))]
    assert quoted, [r["quantity"] for r in rows]
    for label, rise in quoted:
        assert rise == table_rise["copper"] or "mean" in label, (label, table_rise)
    assert all("mean target temperature" in r["how"] for r in rows if "mean rise" in r["quantity"])


def test_a_calibration_without_repeats_is_judged_against_the_measured_noise(campaign_files):
    """No position error without a valid calibration: the steel sweep at 15 kHz has no repeated readings, so its
    calibration's own noise was its residual's spread and no residual could fail against it. With the sweep
    distorted by 3 % along x (a calibration the model cannot follow) the figure read as a length (37.6 mm); it is
    judged against the noise the repeated readings measured and reads "model fails here"."""
    from dataclasses import replace

    from ecds_lab.analysis.quantities import MODEL_FAILS, VALID

    steel = next(open_data(p) for p in campaign_files if open_data(p).sensor.target == "steel")
    air = next(open_data(p).data for p in campaign_files if open_data(p).run.kind == "coil_heating")
    d = steel.data
    sweep = np.isfinite(d.x_m) & (d.freq_hz == 15000.0)

    def room_15k(amplitude: float) -> dict:
        bump = np.where(sweep, 1 + amplitude * np.sin(np.nan_to_num(d.x_m) * 2 * np.pi / 0.03), 1.0)
        summary = fit_summary(Measurements.concatenate([replace(d, ls_h=d.ls_h * bump), air]), [], steel.sensor)
        assert summary["noise_method"] == "repeated readings"
        return next(c for c in summary["calibration"] if c["freq_hz"] == 15000.0)["all_points"]

    assert room_15k(0.0)["room_temperature"]["status"] == VALID
    distorted = room_15k(0.03)
    assert distorted["room_temperature"]["status"] == MODEL_FAILS, distorted["room_temperature"]
    assert distorted["room_temperature"]["max_abs_mm"] is None
    assert distorted.get("target_heated", {}).get("max_abs_mm") is None


def test_every_output_of_the_steady_eq4_says_how_many_glitch_readings_it_left_out(outputs, campaign_report):
    """The demo's coil heating has a glitch in a steady step at 500 Hz (the one that moved alpha, issue 24 point 1):
    the fit JSON, the paper row and the report's Eq. (4) table each say it was left out, with one count."""
    fit, rows, html = outputs
    counts = {e["freq_hz"]: e["glitches_excluded"] for e in fit["eq4_steady"]}
    assert counts.get(500.0, 0) >= 1, counts
    coil = next(r for r in rows if r["quantity"].startswith("coil heated")
                and "compensated with Eq. 4" in r["quantity"])
    assert f"{counts[500.0]} glitch reading(s) left out of the steady means" in coil["how"]
    heating = _section(html, "heating")
    assert f"{counts[500.0]} glitch reading(s) left out of the steady means" in heating


def test_a_failing_fit_does_not_deny_the_positions_its_calibrations_give(campaign_report):
    """The fit section said the failing baseline's parameters 'describe no coil and give no positions', while the
    position table, a section later, gave lengths from calibrations holding those parameters. Both now say what the
    calibrations take from that fit and on what their positions rest (their own residual)."""
    html = campaign_report.html
    fit, position = _section(html, "fit"), _section(html, "position")
    lengths = re.findall(r'data-q="position_error\.max_abs_mm\.[^"]+" data-v="([0-9.eE+-]+)"', position)
    assert lengths and "model fails here" in fit
    assert "give no positions" not in fit.replace("give no positions of their own", "")
    assert "refits L0 and p1..p4 on its room-temperature sweep" in fit
    assert "the other parameters held at the model fit" in position


def test_every_table_2_row_says_what_its_circuit_fit_leaves(outputs, campaign_report):
    """The spectroscopy table shows each parallel RLC fit's residual (8 % of |Z| at room temperature in the demo);
    the paper rows quoting that fit's L_p, C_p and R_p said it only where R_p differed, so a C_p 'agrees' came
    without it. Each row now names the residual of the fit it quotes, the figure the spectroscopy table shows."""
    _, rows, html = outputs
    table2 = [r for r in rows if r["quantity"].startswith("Table 2")]
    assert table2
    spectroscopy = _section(html, "spectroscopy")
    for row in table2:
        residual = re.search(r"which leaves ([0-9]+) ppm of \|Z\|", row["how"])
        assert residual, row
        assert f"<td>{residual.group(1)}</td>" in spectroscopy, (row["how"], residual.group(1))


def test_the_measured_alpha_and_the_expansion_estimate_are_not_left_side_by_side_without_a_word(campaign_report):
    """The Eq. (4) table gave alpha 2.741 ppm/K at 500 Hz and -192.6 ppm/K at 15 kHz, and its caption 'the former's
    expansion alone gives alpha = 15 ppm/K' with nothing between them. The caption now names the frequencies whose
    alpha is far from it."""
    heating = _section(campaign_report.html, "heating").replace("&#x27;", "'")
    caption = heating[heating.index("The former's expansion alone"):]
    caption = caption[:caption.index("</caption>")]
    assert "the steady points give" in caption and "15000 Hz" in caption, caption
