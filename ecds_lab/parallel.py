"""Independent jobs (one diagnosis per campaign) run in parallel on Dask (``dask.distributed``).

A local cluster of worker processes by default, or an existing Dask cluster across machines given by
its scheduler address (``--scheduler tcp://host:8786``). Dask is an optional extra,
``pip install 'ecds-lab[cluster]'``: without it, jobs on this machine run one after another and the
caller is told so; a scheduler address without it is an error. Nothing here distributes work itself.
Each job must be a module-level function (workers import it) that returns its result, errors included:
one campaign's failure is its own row, never the end of the batch.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from ecds_lab.errors import EcdsLabError

log = logging.getLogger("ecds_lab.parallel")

T = TypeVar("T")
R = TypeVar("R")


class ParallelError(EcdsLabError, ValueError):
    """The parallel engine cannot be used as asked (not installed, scheduler unreachable)."""


def dask_available() -> bool:
    """Whether ``dask.distributed`` can be imported (the ``cluster`` extra)."""
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        return False
    return True


def run_all(job: Callable[[T], R], items: Sequence[T], *, scheduler: str | None = None,
            workers: int | None = None) -> list[R]:
    """``job(item)`` for every item, in the items' order: on the Dask cluster at ``scheduler``, or on a
    local cluster of ``workers`` single-threaded processes (default: one per core)."""
    if workers is not None and workers < 1:
        raise ParallelError(f"--workers must be at least 1, got {workers}")
    if not items:
        return []
    if not dask_available():
        if scheduler:
            raise ParallelError(f"--scheduler {scheduler}: dask.distributed is not installed "
                                "(pip install 'ecds-lab[cluster]')")
        log.warning("dask.distributed is not installed (pip install 'ecds-lab[cluster]'): "
                    "running %d jobs one after another", len(items))
        return [job(item) for item in items]
    if scheduler is None and (workers == 1 or len(items) == 1):
        return [job(item) for item in items]
    return _on_dask(job, items, scheduler, workers)


def _on_dask(job: Callable[[T], R], items: Sequence[T], scheduler: str | None, workers: int | None) -> list[R]:
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as error:
            raise ParallelError(f"--scheduler {scheduler}: cannot reach the Dask scheduler ({error})") from error
        with client:
            return _gathered(client, job, items)
    count = min(workers or os.cpu_count() or 1, len(items))
    # One thread per worker process: each diagnosis is CPU-bound Python and numpy; the analysis keeps
    # BLAS to one thread itself.
    with LocalCluster(n_workers=count, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        return _gathered(client, job, items)


def _gathered(client: Any, job: Callable[[T], R], items: Sequence[T]) -> list[R]:
    futures = client.map(job, list(items), pure=False)
    return list(client.gather(futures))
