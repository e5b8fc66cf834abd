"""The report's chapter "How the question was decided", from an investigate.json in the documented form."""

from __future__ import annotations

import json

import pytest

from ecds_lab.report.investigation import find_investigation, investigation_section, load_investigation

RECORD = {
    "rounds": [
        {"round": 1, "open_questions": [{"kind": "tie", "effects": ["target_bending", "target_tau_temperature"],
                                         "text": "which of target_bending or target_tau_temperature"}],
         "candidates": [], "chosen": {"name": "target_hot_500hz", "what": "the target hot at 500 Hz", "hours": 0.72},
         "why": "decides the tie", "predicted_delta_chi2": 148.2, "measured_delta_chi2": 57.9,
         "measured": {"winner": "target_bending"}, "run_file": "round-1.h5", "run_status": "completed",
         "diagnosis": {"verdict": "inconclusive"},
         "diagnosis_after": {"verdict": "missing_effect", "claimed": ["target_bending"], "alternatives": []}},
        {"round": 2, "open_questions": [], "candidates": [], "chosen": None, "why": "no open question",
         "predicted_delta_chi2": None, "measured_delta_chi2": None, "run_file": None, "diagnosis": {}},
    ],
    "final": {"verdict": "missing_effect", "claimed": ["target_bending"]},
    "stopped": "no open question: nothing to measure", "hours_spent": 0.72,
}


def test_the_chapter_shows_each_round_its_prediction_measurement_and_verdict(tmp_path):
    (tmp_path / "investigate.json").write_text(json.dumps(RECORD), encoding="utf-8")
    (tmp_path / "round-1.h5").write_bytes(b"")
    found = find_investigation([tmp_path / "round-1.h5"])
    assert found == tmp_path / "investigate.json"
    page = "".join(investigation_section(load_investigation(found)))
    assert "target_bending, target_tau_temperature" in page and "the target hot at 500 Hz (0.72 h)" in page
    assert "148.2" in page and "57.9 (target_bending fits best)" in page
    assert "missing_effect: target_bending" in page and "no open question: nothing to measure" in page


def test_a_file_that_is_no_investigation_is_named(tmp_path):
    bad = tmp_path / "investigate.json"
    bad.write_text("{}", encoding="utf-8")
    with pytest.raises(ValueError, match=r"investigate\.json"):
        load_investigation(bad)
