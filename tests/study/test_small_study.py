"""A small validation study of the diagnosis (issue 23) on a two-worker local Dask cluster (issue 25):
20 campaigns drawn from the faithful lab, each diagnosed and judged against its truth, must meet the
study's targets. ``benchmarks/validation_study.py`` runs the large one."""

from __future__ import annotations

import pytest

from ecds_lab.study import run_study
from ecds_lab.study.cases import draw_cases
from ecds_lab.study.scoring import format_study, rates

pytest.importorskip("dask.distributed", reason="the cluster extra (dask.distributed) is not installed")

CASES, SEED = 20, 1


@pytest.fixture(scope="module")
def judgements():
    return run_study(CASES, SEED, workers=2)


def test_the_study_runs_every_case_in_order_on_two_workers(judgements):
    assert [j.case for j in judgements] == draw_cases(CASES, SEED)
    assert all(j.error is None for j in judgements), format_study(judgements, SEED)


def test_the_small_study_meets_the_targets(judgements):
    figures = rates(judgements)
    table = format_study(judgements, SEED)
    assert figures.null_cases >= 3 and figures.judged_cases >= 10, table  # the draw exercises both kinds
    assert figures.wrong_claim_rate <= 0.02, table
    assert figures.false_alarm_rate <= 0.05, table
    assert figures.right_rate >= 0.85, table
