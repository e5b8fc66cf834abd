"""Rows of the paper comparison: the contract's keys, the paper's methods, and honest disagreement."""

from __future__ import annotations

import pytest

from ecds_lab.analysis.paper_comparison import _row, target_rows
from ecds_lab.simulators.campaign import target_heating
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

KEYS = {"quantity", "paper", "ecds_lab", "unit", "agrees", "how"}


def test_a_row_that_differs_says_why_and_one_that_agrees_does_not():
    differs = _row("q", "≈10", 100.0, "ratio", False, "how it was computed", "the reason")
    agrees = _row("q", "≈10", 9.0, "ratio", True, "how it was computed", "the reason")
    assert set(differs) == KEYS and differs["how"].endswith("Differs: the reason")
    assert agrees["how"] == "how it was computed"


@pytest.fixture(scope="module")
def copper_heating():
    lab = SimulatedLab(LabConfig(physics="field", seed=5))
    return target_heating(lab, setpoints_c=(22.0, 132.0), positions_mm=(20.0, 30.0, 40.0, 60.0, 80.0, 100.0),
                          directions=("forward",))


def test_target_rows_follow_the_paper_on_the_faithful_copper_plate(copper_heating):
    by_name = {r["quantity"]: r for r in target_rows(copper_heating, None)}
    assert all(set(r) == KEYS for r in by_name.values())
    at_15k = next(r for q, r in by_name.items() if "15 kHz, max" in q)
    at_500 = next(r for q, r in by_name.items() if "500 Hz, max" in q)
    bending = next(r for q, r in by_name.items() if "bending" in q)
    assert at_15k["ecds_lab"] < at_500["ecds_lab"]  # paper: target effects amplified at 500 Hz
    assert at_15k["agrees"] and bending["agrees"] and bending["ecds_lab"] < 0
