"""The diagnosis prints no position error where the model fails (issue 24, point 2): on the shipped steel run the
baseline leaves far more than the noise, and `diagnose` printed a position error of 19,723 mm (24,654 % FS)."""

from __future__ import annotations

import json
import re

from ecds_lab.analysis.quantities import MODEL_FAILS, MODEL_FAILS_FACTOR
from ecds_lab.cli import main

#: A length in the text: a number with a unit of length (mm, µm, m...), as a position error is printed.
LENGTH = re.compile(r"position error [-+0-9.,]+ *(?:[kmµun]?m)\b")


def test_diagnose_prints_no_position_error_where_the_model_fails(shipped_run, capsys):
    steel = shipped_run("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml").path
    assert main(["diagnose", str(steel), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    failing = [s for s in report["steps"] if s["rmse_ppm"] > MODEL_FAILS_FACTOR * report["noise_ppm"]]
    assert failing, "the steel baseline should fail (residual far above the noise)"
    for step in failing:
        assert step["position_error"]["status"] == MODEL_FAILS
        assert step["position_error_mm"] is None and step["position_error_fs_pct"] is None
    if report["baseline"]["rmse_ppm"] > MODEL_FAILS_FACTOR * report["noise_ppm"]:
        assert report["baseline"]["rmse_mm"] is None and report["baseline"]["position_error"]["status"] == MODEL_FAILS
    assert "noise_details" in report and "warnings" in report["noise_details"]
    assert main(["diagnose", str(steel)]) == 0
    text = capsys.readouterr().out
    assert MODEL_FAILS in text
    lines = text.splitlines()
    start = lines.index("steps:") + 1
    for step, line in zip(report["steps"], lines[start:start + len(report["steps"])], strict=True):
        assert line.strip().startswith(" + ".join(["baseline", *step["effects"]]))
        if step in failing:  # a failing model's line carries no length
            assert not LENGTH.search(line), line
    explanation = report["explanation"]
    if not any(s["position_error"]["status"] == "valid" for s in report["steps"]):
        assert not LENGTH.search(explanation), explanation
