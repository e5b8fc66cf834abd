"""The chain table says why a step's effect is not claimed: a tied group it stands for, or the structure a partial
explanation of a residual outside the library leaves where it acts."""

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
