"""Keep freed memory for reuse while fitting (glibc): model evaluations over many readings allocate and free
dozens of arrays of n values each, and glibc by default hands freed blocks above its thresholds back to the
system, so the next evaluation faults the same pages in again, one by one. On 10^5 readings that was most of
a Jacobian's time (36 ms, 14 ms with freed memory kept; the whole fit summary 5.3 -> 3.9 s CPU).

``retain_freed_memory()`` raises glibc's ``M_MMAP_THRESHOLD`` (arrays up to 32 MiB, 4 million values, come
from the heap) and ``M_TRIM_THRESHOLD`` (up to 512 MiB of freed heap is kept) through ``mallopt`` (malloc.h;
mallopt(3)), once per process. The peak memory is unchanged; the process keeps it until it ends. Elsewhere
(another C library) it does nothing.
"""

from __future__ import annotations

import ctypes
import threading

#: mallopt parameters (glibc malloc.h) and the values set.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024  # glibc's largest (HEAP_MAX_SIZE / 2 on 64-bit)
_TRIM_THRESHOLD_BYTES = 512 * 1024 * 1024
_lock = threading.Lock()
_done = False


def retain_freed_memory() -> bool:
    """Set glibc's thresholds once (see the module); True if this process's C library took them."""
    global _done
    with _lock:
        if _done:
            return True
        try:
            mallopt = ctypes.CDLL(None).mallopt
        except (OSError, AttributeError):  # not glibc (musl, macOS, Windows): nothing to tune
            return False
        mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
        _done = bool(mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_BYTES)) & bool(
            mallopt(_M_TRIM_THRESHOLD, _TRIM_THRESHOLD_BYTES))
        return _done
