"""One BLAS thread while fitting: the fits factor tall, thin matrices (n readings x k parameters),
where BLAS threads bring nothing and, on a machine whose cores are busy, cost a hundredfold
(an SVD of 900 x 12 took 0.1 s with two contended threads, 0.2 ms with one).

``one_blas_thread()`` limits the BLAS libraries numpy and scipy load (OpenBLAS, MKL, BLIS, on any
platform) to one thread and restores their setting afterwards, through threadpoolctl. The libraries
are looked up once, after numpy and scipy.linalg are imported (so their BLAS is loaded).
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from functools import lru_cache

from threadpoolctl import ThreadpoolController

_lock = threading.Lock()


@lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    """The thread pools of the BLAS libraries loaded by numpy and scipy (found once: a lookup walks every
    library mapped into the process)."""
    import numpy  # noqa: F401  (its BLAS must be loaded to be found)
    import scipy.linalg  # noqa: F401

    return ThreadpoolController().select(user_api="blas")


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the body with the BLAS libraries on one thread (nested use is fine)."""
    with _lock:
        limiter = _controller().limit(limits=1)
    try:
        yield
    finally:
        with _lock:
            limiter.restore_original_limits()
