"""One BLAS thread while fitting: the fits factor tall, thin matrices (n readings x k parameters),
where OpenBLAS threads bring nothing and, on a machine whose cores are busy, cost a hundredfold
(an SVD of 900 x 12 took 0.1 s with two contended threads, 0.2 ms with one).

``one_blas_thread()`` sets the OpenBLAS libraries numpy and scipy load to one thread and restores
their setting afterwards, through OpenBLAS's own ``*_set_num_threads`` (as threadpoolctl does).
Where no such library is loaded (another BLAS) it does nothing.
"""

from __future__ import annotations

import ctypes
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_PREFIXES = ("scipy_openblas", "openblas")
_SUFFIXES = ("64_", "")
_lock = threading.Lock()
_controls: list[tuple[object, object]] | None = None


def _find_controls() -> list[tuple[object, object]]:
    """(get, set) function pairs of every OpenBLAS library mapped into this process (Linux)."""
    paths: set[str] = set()
    try:
        with open("/proc/self/maps") as maps:
            paths = {line.split()[-1] for line in maps if "openblas" in line.lower() and ".so" in line}
    except OSError:
        return []
    controls = []
    for path in sorted(p for p in paths if p.startswith("/")):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for prefix in _PREFIXES:
            pair = None
            for suffix in _SUFFIXES:
                get, put = f"{prefix}_get_num_threads{suffix}", f"{prefix}_set_num_threads{suffix}"
                if hasattr(lib, get) and hasattr(lib, put):
                    getter, setter = getattr(lib, get), getattr(lib, put)
                    getter.restype, setter.argtypes = ctypes.c_int, [ctypes.c_int]
                    pair = (getter, setter)
                    break
            if pair:
                controls.append(pair)
                break
    return controls


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the body with OpenBLAS on one thread (nested use is fine)."""
    global _controls
    import numpy  # noqa: F401  (its BLAS must be loaded to be found)
    import scipy.linalg  # noqa: F401

    with _lock:
        if _controls is None:
            _controls = _find_controls()
        saved = [(setter, getter()) for getter, setter in _controls]  # type: ignore[operator]
        for setter, _ in saved:
            setter(1)  # type: ignore[operator]
    try:
        yield
    finally:
        with _lock:
            for setter, threads in saved:
                setter(threads)  # type: ignore[operator]
