"""A small validation study on a two-worker local Dask cluster (issue 25): short campaigns with chosen truths,
each measured on the faithful lab, diagnosed on a worker and judged against its truth, in order.

The study's target rates (issue 23) are measured by ``benchmarks/validation_study.py`` on 200 random
campaigns; a random draw of 20 includes long two-heater campaigns whose diagnosis takes minutes, too long
for CI, so this test checks the machinery on short designs and the rules' verdicts on clear cases."""

from __future__ import annotations

import pytest

from ecds_lab.study import run_study
from ecds_lab.study.cases import Case, Design, merged, truth_kinds
from ecds_lab.study.scoring import format_study

pytest.importorskip("dask.distributed", reason="the cluster extra (dask.distributed) is not installed")

SHORT_BOTH_WAYS = Design((15000.0,), ("forward", "backward"), 9, False, (), (), 1)
SHORT_TWO_FREQUENCIES = Design((500.0, 15000.0), ("forward",), 9, False, (), (), 1)
SHORT_HEATED_ONE_FREQUENCY = Design((15000.0,), ("forward", "backward"), 9, False, (75.0,), (), 1)


def case(number: int, design: Design, *truths: str, seed: int = 11) -> Case:
    import numpy as np

    rng = np.random.default_rng(number)
    blocks: dict = {}
    for name in truths:
        blocks = merged(blocks, truth_kinds()[name].block(rng))
    return Case(number, seed + number, design, truths, blocks)


CASES = [case(0, SHORT_BOTH_WAYS), case(1, SHORT_BOTH_WAYS, "backlash"), case(2, SHORT_TWO_FREQUENCIES),
         case(3, SHORT_BOTH_WAYS, "glitches"), case(4, SHORT_HEATED_ONE_FREQUENCY, "bending")]


@pytest.fixture(scope="module")
def judgements():
    return run_study(len(CASES), 0, workers=2, cases=CASES)


def test_every_case_is_diagnosed_in_order_on_two_workers(judgements):
    assert [j.case for j in judgements] == CASES
    assert all(j.error is None for j in judgements), format_study(judgements, 0)
    assert all(j.diagnosis_cpu_s is not None and j.diagnosis_cpu_s > 0 for j in judgements)  # each one's cost is kept
    assert all(j.to_json()["diagnosis_cpu_s"] == j.diagnosis_cpu_s for j in judgements)


def test_clear_cases_are_judged_right(judgements):
    table = format_study(judgements, 0)
    null, backlash, two_frequencies, glitches, bending = judgements
    assert null.null and null.right and not null.false_alarm, table
    assert backlash.found == ["backlash"] and not backlash.wrong_claims, table
    assert two_frequencies.null and not two_frequencies.wrong_claims, table  # tau_displacement is true here
    assert glitches.null and not glitches.false_alarm, table
    # at one frequency a bending may be claimed or honestly tied with a conductivity change, never missed
    assert bending.found == ["bending"] and not bending.wrong_claims, table
