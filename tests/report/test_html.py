"""``write_report`` and ``ecds-lab report``: one self-contained HTML page with every section the data support."""

from __future__ import annotations

import base64
import re
import sys
from pathlib import Path

import pytest

from ecds_lab.cli import main
from ecds_lab.report.html import write_report
from ecds_lab.storage.data_file import open_data

SESSIONS = Path(__file__).resolve().parent.parent / "data" / "sessions"
IMG = re.compile(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)" width="(\d+)" height="(\d+)" alt="([^"]*)"')


def images(html: str) -> list[tuple[bytes, int, int, str]]:
    return [(base64.b64decode(m[0]), int(m[1]), int(m[2]), m[3]) for m in IMG.findall(html)]


def section(html: str, anchor: str) -> str:
    """The HTML of one section, by its heading's id."""
    start = html.index(f'<h2 id="{anchor}">')
    end = html.find("<section>", start)
    return html[start:end if end > 0 else len(html)]


def test_campaign_report_is_one_self_contained_page_with_every_section(campaign_report):
    html = campaign_report.html
    assert html.startswith("<!DOCTYPE html>") and html.rstrip().endswith("</html>")
    assert "<script" not in html and not re.search(r"""(src|href)=["']?(https?:|//)""", html)
    for anchor in ("runs", "fit", "residuals", "diagnosis", "position", "heating", "spectroscopy"):
        assert f'<h2 id="{anchor}">' in html
    pictures = images(html)
    assert len(pictures) >= 12
    for data, width, height, alt in pictures:
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and alt
        assert (int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")) == (width, height)
    print(f"\ncampaign report: {campaign_report.path} ({campaign_report.seconds:.1f} s, {len(html) / 1e6:.1f} MB)")


def test_runs_section_shows_experiment_station_instruments_status_and_points(campaign_report):
    runs = section(campaign_report.html, "runs")
    assert "displacement sweep 20-100 mm" in runs and "kind: spectroscopy" in runs
    assert "simulated lab (steel target)" in runs and "target: steel" in runs
    assert "HAMEG Instruments, HM8118" in runs and "Grbl 1.1h" in runs and "DAQ970A" in runs and "HMP4040" in runs
    assert runs.count(">completed<") == 5
    assert "248 readings" in runs and "lab clock" in runs
    assert "model fit: copper target, steel target" in runs  # the coil in air serves both targets
    assert "<td>spectroscopy</td>" in runs


def test_sections_show_the_papers_figures_and_tables(campaign_report):
    html = campaign_report.html
    fit = section(html, "fit")
    assert "Fig. 6" in fit and "Fig. 7" in fit and "copper target: baseline fit" in fit and "mH" in fit
    position = section(html, "position")
    assert "Fig. 14 and 22" in position and "Fig. 20 and 23" in position and "n = 4" in position
    assert "Micro-Epsilon EU80" in position and "Kaman KDM-8206" in position and "ATO ECDS-5060" in position
    assert "−11 … 18" in position and "&lt; 22" in position
    assert "uncompensated" in position and "built the paper&#x27;s way" in position
    # a steel target barely changes L at 500 Hz: that frequency is not calibrated, and the report says why
    assert "steel target at 500 Hz not calibrated" in position
    heating = section(html, "heating")
    assert "Eq. (4)" in heating and "ppm/K" in heating and "Fig. 17" in heating
    spectroscopy = section(html, "spectroscopy")
    assert "Table 2" in spectroscopy and "62.5" in spectroscopy and spectroscopy.count("spectroscopy.h5") == 3


def test_diagnosis_section_shows_ranking_explanation_and_before_after(campaign_report):
    diagnosis = section(campaign_report.html, "diagnosis")
    assert "missing effect" in diagnosis
    assert "Stand-in explanation &lt;for the test&gt; &amp; more." in diagnosis  # escaped, not markup
    assert "target_tau_temperature" in diagnosis and "ΔBIC" in diagnosis and "t_target_c" in diagnosis
    assert len(images(diagnosis)) == 2 and "Residuals before" in diagnosis


def test_csv_input_shows_file_and_rows_and_notes_what_the_data_cannot_support(campaign_files, stand_in, tmp_path):
    csv = tmp_path / "sweep.csv"
    open_data(campaign_files[0]).data.to_csv(csv)
    output = write_report([csv], tmp_path / "out" / "report.html", workers=1,
                          diagnosis=stand_in(open_data(csv).data))
    html = output.read_text()
    runs = section(html, "runs")
    assert "<td>sweep.csv</td><td>248</td>" in runs and "kind:" not in runs
    notes = re.findall(r'<p class="omitted"><strong>Omitted:</strong> ([^<]*)</p>', html)
    assert any(n.startswith("no coil-heating data: no readings of the coil in air") for n in notes)
    assert any(n.startswith("no spectroscopy data") for n in notes)
    assert any(n.startswith("no target-heating position error") for n in notes)
    assert any(n.startswith("no coil-heating position error") for n in notes)
    assert any(n.startswith("the diagnosis") for n in notes) or 'id="diagnosis"' in html
    assert len(images(html)) >= 5


def test_spectroscopy_alone_notes_that_there_is_nothing_for_the_model(campaign_files, tmp_path):
    html = write_report([campaign_files[2]], tmp_path / "spectra.html", workers=1).read_text()
    for anchor in ("fit", "residuals", "diagnosis", "position"):
        assert "no data for the sensor model: no readings, or only spectroscopy recordings" in section(html, anchor)
    assert "no coil-heating data" in section(html, "heating")
    assert len(images(section(html, "spectroscopy"))) == 1


def test_a_failed_run_shows_its_fault(tmp_path):
    html = write_report([SESSIONS / "instrument_error.h5"], tmp_path / "failed.html", workers=1).read_text()
    runs = section(html, "runs")
    assert 'class="badge bad">failed<' in runs
    assert "InstrumentError: bridge: command &#x27;FREQ 15000&#x27; failed" in runs
    assert "of 12 planned points measured" in runs


def test_without_the_diagnosis_module_the_section_says_so(monkeypatch, campaign_files, tmp_path):
    monkeypatch.setitem(sys.modules, "ecds_lab.analysis.diagnosis", None)  # import fails
    html = write_report([campaign_files[0]], tmp_path / "r.html", workers=1).read_text()
    assert "the diagnosis is not available in this installation" in section(html, "diagnosis")


def test_cli_writes_the_report_with_the_real_diagnosis(tmp_path, capsys):
    pytest.importorskip("ecds_lab.analysis.diagnosis")
    output = tmp_path / "cli.html"
    assert main(["report", str(SESSIONS / "sweep.h5"), "-o", str(output)]) == 0
    assert f"report -> {output}" in capsys.readouterr().out
    diagnosis = section(output.read_text(), "diagnosis")
    assert re.search(r'class="badge (good|bad)">(adequate|missing effect)<', diagnosis)
    assert 'class="explanation"' in diagnosis and "Omitted" not in diagnosis


def test_a_run_without_readings_is_listed_with_its_fault(tmp_path):
    from ecds_lab.storage.run_file import RunWriter, metadata_for

    run = tmp_path / "empty.h5"
    metadata = metadata_for("kind: displacement_sweep\n", "name: bench\n", "sweep", "displacement_sweep",
                            planned_points="10")
    writer = RunWriter(run, metadata=metadata,
                       transcripts={}, identities={"bridge": "HAMEG Instruments, HM8118,1,1.57"})
    writer.close("failed", "InstrumentError: bridge: no reply to *IDN?")
    html = write_report([run], tmp_path / "r.html", workers=1).read_text()
    runs = section(html, "runs")
    assert "bench" in runs and "HM8118" in runs and "no reply to *IDN?" in runs and "holds no bridge readings" in runs
    assert "no readings, or only spectroscopy recordings" in section(html, "fit")
