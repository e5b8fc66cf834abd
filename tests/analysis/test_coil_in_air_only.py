"""A campaign of the coil in air alone (a coil-heating characterisation) has no position: the diagnosis's text, its
command-line table and the report's chain say so, instead of a position error "out of range (no readings)"."""

from __future__ import annotations

import json

import pytest

from ecds_lab.analysis.diagnosis import format_diagnosis, run_diagnosis
from ecds_lab.report.sections import NO_POSITIONS, _chain_table
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.study.campaigns import QUIET_LAB
from ecds_lab.study.cases import merged


@pytest.fixture(scope="module")
def in_air():
    """The faithful lab's former drying in air as it heats to 60 and 100 C."""
    config = LabConfig(physics="field", seed=3, **merged(QUIET_LAB, {"former": {"moisture": {"enabled": True}}}))
    return run_diagnosis(campaign.coil_heating(SimulatedLab(config), (60, 100), interval_s=300.0))


def test_the_text_has_no_position_error_where_no_reading_has_a_position(in_air):
    assert len(in_air.steps) > 1, in_air.explanation
    assert "position error" not in in_air.explanation and "no readings" not in in_air.explanation
    table = format_diagnosis(json.loads(json.dumps(in_air.to_json())))
    assert "out of range" not in table and "position error" not in table.split("candidates")[0]


def test_the_reports_chain_says_there_is_no_position(in_air):
    html = str(_chain_table(in_air.steps, in_air.noise_ppm))
    assert NO_POSITIONS in html and "out of range" not in html
