"""A size question (an effect with clear evidence and its size undetermined) is decided by the separation that lets
the joined campaign hold the size MIN_Z standard errors from zero, as the diagnosis needs to claim it
(choice.needed_separation, docs/planning.md, Scoring): the two size rivals sit two standard errors apart, so a run
separating them by Delta adds Delta/4 of the start's information, and z^2 (1 + Delta/4) >= MIN_Z^2."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ecds_lab.analysis.diagnosis.checks import MIN_Z
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import library
from ecds_lab.planning.choice import needed_separation
from ecds_lab.planning.discrimination import DECISIVE_CHI2
from ecds_lab.planning.questions import OpenQuestion


def _started(value: float, error: float):
    """A diagnosis whose last round fitted thermal_lag at ``value`` +- ``error`` (s)."""
    fit = SimpleNamespace(values={"lag_tau": value}, stderr={"lag_tau": error},
                          model=SimpleNamespace(sensor=SensorConfig()))
    return SimpleNamespace(steps=[SimpleNamespace(candidates=[SimpleNamespace(effect="thermal_lag", fit=fit)])])


SIZE = OpenQuestion("undetermined", ("thermal_lag",), "how large is thermal_lag")


def test_a_size_near_determined_needs_little():
    # issue 26 (d): lag_tau 1479 +- 528 s, z 2.80
    need = needed_separation(SIZE, _started(1479.0, 528.0), library())
    assert need == pytest.approx(4 * (MIN_Z**2 / (1479.0 / 528.0) ** 2 - 1))
    z_after = (1479.0 / 528.0) * (1 + need / 4) ** 0.5
    assert z_after == pytest.approx(MIN_Z)


def test_a_size_far_from_determined_needs_more_than_a_tie():
    assert needed_separation(SIZE, _started(100.0, 100.0), library()) == pytest.approx(32.0)


def test_a_size_already_three_errors_from_zero_and_a_tie_keep_the_decisive_figure():
    assert needed_separation(SIZE, _started(1500.0, 300.0), library()) == DECISIVE_CHI2
    tie = OpenQuestion("tie", ("parasitic_capacitance", "thermal_lag"), "which")
    assert needed_separation(tie, _started(1479.0, 528.0), library()) == DECISIVE_CHI2
