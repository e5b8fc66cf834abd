"""The validation study of the diagnosis: many campaigns drawn at random from the simulated lab (random truths,
random designs), each diagnosed in parallel on Dask (``ecds_lab.parallel``), judged against its truth.

``cases`` draws truths and designs, ``campaigns`` measures a case on the faithful lab, ``scoring`` judges and
tabulates. ``benchmarks/validation_study.py`` runs the large study; ``tests/study`` a small one.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

from ecds_lab.errors import EcdsLabError
from ecds_lab.parallel import run_all
from ecds_lab.study.cases import Case, draw_cases
from ecds_lab.study.scoring import Judgement, judge


def study_case(case: Case) -> Judgement:
    """Measure one case and judge its diagnosis (runs on a worker)."""
    from ecds_lab.analysis.diagnosis import diagnose
    from ecds_lab.study.campaigns import measure, sensor_of

    try:
        data = measure(case)
        began = time.process_time()
        report = diagnose(data, sensor=sensor_of(case))
    except (EcdsLabError, ValueError, ArithmeticError) as error:
        return judge(case, None, f"{type(error).__name__}: {error}")
    judgement = judge(case, report)
    judgement.diagnosis_cpu_s = time.process_time() - began
    return judgement


def run_study(count: int, seed: int, *, scheduler: str | None = None, workers: int | None = None,
              cases: Sequence[Case] | None = None, sensors: Sequence[str] = ("paper",)) -> list[Judgement]:
    """``count`` cases drawn from ``seed`` on ``sensors`` (or the given ones), each measured, diagnosed and judged,
    in order."""
    return run_all(study_case, list(cases) if cases is not None else draw_cases(count, seed, sensors),
                   scheduler=scheduler, workers=workers)
