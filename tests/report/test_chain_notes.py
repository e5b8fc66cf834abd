"""The chain table says why a step's effect is not claimed: a tied group it stands for, or the structure a partial
explanation of a residual outside the library leaves where it acts; and beside what a claim was judged when a
smooth took a residual outside the library."""

from __future__ import annotations

from types import SimpleNamespace

from ecds_lab.report.sections import _tie_note


def test_a_claimed_step_has_no_note():
    assert _tie_note(SimpleNamespace(stands_for=[], leaves_structure=None)) == ""


def test_a_tie_names_its_group():
    note = _tie_note(SimpleNamespace(stands_for=["target_bending", "target_tau_temperature"], leaves_structure=None))
    assert "target_bending / target_tau_temperature" in note and "not claimed" in note


def test_a_partial_explanation_says_what_it_leaves():
    note = _tie_note(SimpleNamespace(stands_for=[], leaves_structure=38.4))
    assert "outside the library" in note and "38 sd" in note and "not claimed" in note


def test_a_part_of_a_drift_says_what_it_keeps():
    note = _tie_note(SimpleNamespace(stands_for=[], leaves_structure=None, part_of_drift=-0.59))
    assert "drift in time" in note and "keeps 0 %" in note and "not claimed" in note
    assert _tie_note(SimpleNamespace(stands_for=[], leaves_structure=None, part_of_drift=None)) == ""


def test_a_claim_beside_a_smooth_names_its_variables():
    note = _tie_note(SimpleNamespace(stands_for=[], leaves_structure=None, part_of_drift=None, beside=["time_s"]))
    assert "claimed beside a smooth in time_s" in note and "outside the library" in note and "not claimed" not in note
    assert _tie_note(SimpleNamespace(stands_for=[], leaves_structure=None, part_of_drift=None, beside=[])) == ""
