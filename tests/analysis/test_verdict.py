"""The verdict from the chain of models: a residual outside the library is a missing effect, a tie beside it or not."""

from __future__ import annotations

from types import SimpleNamespace

from ecds_lab.analysis.diagnosis.structure import ResidualStructure
from ecds_lab.analysis.diagnosis.verdict import verdict_of

NOISE = SimpleNamespace(ppm=20.0)
STRUCTURED = ResidualStructure(400.0, 100, 28.0)
FLAT = ResidualStructure(0.0, 100, -0.5)


def _chain(final_rmse_ppm: float, *, claims: bool = False) -> list:
    base = SimpleNamespace(rmse_ppm=100.0, candidates=["a candidate"], claims=False)
    representative = SimpleNamespace(rmse_ppm=final_rmse_ppm, candidates=[], claims=claims)
    return [base, representative]


def test_a_tie_beside_a_residual_outside_the_library_is_a_missing_effect():
    """Validation study case 124: bending-or-tau_T tied, and a metal object's bump in x left 13 sd beyond chance."""
    tie = [["target_tau_temperature", "target_bending"]]
    assert verdict_of(_chain(23.0), [], NOISE, STRUCTURED, tie, {}, []) == "missing_effect"


def test_a_tie_that_leaves_the_noise_is_inconclusive():
    tie = [["target_tau_temperature", "target_bending"]]
    assert verdict_of(_chain(20.2), [], NOISE, FLAT, tie, {}, []) == "inconclusive"


def test_a_limit_reached_first_leaves_it_inconclusive():
    tie = [["target_tau_temperature", "target_bending"]]
    limits = ["the search stopped at its limit of 8 added effect(s)"]
    assert verdict_of(_chain(23.0), [], NOISE, STRUCTURED, tie, {}, limits) == "inconclusive"
    assert verdict_of(_chain(23.0), [], NOISE, STRUCTURED, [], {}, limits) == "inconclusive"
