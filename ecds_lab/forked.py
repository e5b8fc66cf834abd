"""Independent pieces of one computation on every CPU: this process and worker processes forked beside it.

A diagnosis fits many models that do not depend on each other: the candidates of a round, the folds of a held-out
error, the alternative starts of a refinement or a repolish. ``each(work, items)`` runs ``work`` over ``items`` in
this process and in processes forked for the call (one fewer than the CPUs allowed), which inherit ``work`` and
everything it closes over (nothing is sent to them); each process takes the next item nobody has taken. Only the
workers' results come back, and the objects the caller names ``shared`` come back as the caller's own objects, not
as copies (a result that refers to the data it was fitted on refers to the caller's data). A result that cannot be
pickled (it refers to a class made at run time that is not shared) is worked again by the caller, and so is every
item a worker took when a worker dies (killed, out of memory) rather than failing.

Nothing is forked unless the caller allows it (``allowed``: the command line allows the CPUs this process may use;
a library call, a test or a Dask worker stays in its own process), where ``fork`` is not available, inside a worker,
or for fewer than two items: ``each`` is then a plain loop. The results are the same either way: each piece is
computed by the same code from the same inputs, and they come back in the items' order."""

from __future__ import annotations

import io
import multiprocessing
import os
import pickle
import signal
import struct
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, TypeVar

T = TypeVar("T")
R = TypeVar("R")
S = TypeVar("S")

#: processes ``each`` may use (1: a plain loop in this process)
_allowed = 1


@dataclass
class _Job:
    """What the forked workers inherit: the work, its items, the objects that go back as references, and the pipe of
    the numbers of the items not yet taken."""

    work: Callable[[Any], Any]
    items: Sequence[Any]
    shared: dict[int, object]
    share: _Share


_job: _Job | None = None


def cpus() -> int:
    """The CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def can_fork() -> bool:
    """Whether this platform starts processes by forking (Linux, and macOS when asked)."""
    return "fork" in multiprocessing.get_all_start_methods()


def workers() -> int:
    """The processes ``each`` may use here and now."""
    return _allowed


@contextmanager
def allowed(workers: int | None = None) -> Iterator[None]:
    """Let ``each`` use up to ``workers`` processes (default: every CPU) within the body."""
    global _allowed
    before = _allowed
    _allowed = max(1, cpus() if workers is None else workers)
    try:
        yield
    finally:
        _allowed = before


def each(work: Callable[[T], R], items: Iterable[T], shared: Iterable[object] = ()) -> list[R]:
    """``[work(item) for item in items]``, shared between this process and up to the allowed number of processes
    less one forked for it; a result's references to an object in ``shared`` are to that very object."""
    return each_beside(None, work, items, shared)[1]


def each_beside(here: Callable[[], S] | None, work: Callable[[T], R], items: Iterable[T],
                shared: Iterable[object] = ()) -> tuple[S | None, list[R]]:  # None: no ``here``
    """``here()`` in this process while the forked workers work ``items`` as in ``each``: a long piece that has no
    use for a worker's result beside short ones that do not need its own (a claim's refit on every reading beside a
    repolish's starts on a subsample); then this process takes its share of the items left. In one process:
    ``here()`` first, then the items.

    Every process takes the next item not yet taken (``_Share``), this one among them, so none waits while items
    are left: with the items handed out in advance, two workers left a CPU idle for a fifth of a 10^5-reading
    diagnosis, a long item ending each set (docs/diagnosis.md)."""
    global _job
    items = list(items)
    workers = min(_allowed - 1, len(items) - 1)
    if workers < 1 or not can_fork() or len(items) > SHARED_ITEMS:
        done = here() if here is not None else None
        return done, [work(item) for item in items]
    kept = {id(obj): obj for obj in shared}
    share = _Share(len(items))
    _job = _Job(work, items, kept, share)
    futures = []
    pool = None
    done = None
    local: dict[int, R] = {}
    payloads: dict[int, bytes | None] = {}
    try:
        try:
            pool = worker_pool(workers)
            futures = [pool.submit(_run_share) for _ in range(workers)]
        except (OSError, BrokenProcessPool):  # no processes to be had, or one died: the items are worked here
            futures = []
        finally:
            _job = None
        done = here() if here is not None else None
        with allowed(1):  # what an item forks of its own it works here, as a worker would
            while (index := share.take()) is not None:
                local[index] = work(items[index])
        try:
            for future in futures:
                payloads.update(future.result())
        except BrokenProcessPool:  # a worker died (killed, out of memory): the items it took are worked here
            payloads.clear()
    finally:
        if pool is not None:
            stop(pool)
        share.close()
    results = []
    for i, item in enumerate(items):
        payload = payloads.get(i)
        results.append(local[i] if i in local else work(item) if payload is None
                       else _Loader(io.BytesIO(payload), kept).load())
    return done, results


#: Most items one call shares out (``_Share``): their numbers, four bytes each, fill a pipe's 64 KiB; a larger set is
#: worked in this process alone.
SHARED_ITEMS = 16_384


class _Share:
    """The numbers of one call's items not yet taken, in order, in a pipe that this process and the workers forked
    from it read: each read of four bytes takes the next. The kernel orders the reads, so a worker that dies
    holds nothing up (a lock in shared memory would stay taken by a worker killed while holding it). Every number
    is written before the workers are forked, so none of them holds the pipe open for writing: at the end, a read
    finds nothing, and no process waits."""

    def __init__(self, count: int) -> None:
        read_end, write_end = os.pipe()
        try:
            os.write(write_end, struct.pack(f"={count}i", *range(count)))
        finally:
            os.close(write_end)
        self.read_end = read_end

    def take(self) -> int | None:
        """The next item's number, now taken, or None when every item is taken."""
        record = os.read(self.read_end, 4)
        return struct.unpack("=i", record)[0] if len(record) == 4 else None

    def close(self) -> None:
        """This process's end of the pipe, closed (a worker's closes as it ends)."""
        os.close(self.read_end)


def worker_pool(workers: int) -> ProcessPoolExecutor:
    """Worker processes forked from this one, each forking none of its own and leaving Ctrl-C to this process (which
    ends them, ``stop``). They are forked at the first submission: whatever that inherits must be in place by then.
    A worker that dies (killed, out of memory) breaks the pool (``BrokenProcessPool``) rather than leaving its work
    waited for."""
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"), initializer=_become_worker)


def stop(pool: ProcessPoolExecutor) -> None:
    """Shut the pool down without waiting for work nobody will collect (after Ctrl-C, say): its workers are ended."""
    workers = list(getattr(pool, "_processes", {}).values())  # the executor's own record of its processes
    pool.shutdown(wait=False, cancel_futures=True)
    for process in workers:
        if process.is_alive():
            process.terminate()


def _become_worker() -> None:
    """A worker works alone (no forks of its own), leaves Ctrl-C to its parent, which stops it, and gives back the
    free memory it inherited (``_give_back_free_memory``)."""
    global _allowed
    _allowed = 1
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _give_back_free_memory()


def _give_back_free_memory() -> None:
    """The free heap memory inherited from the parent, returned to the system (glibc's ``malloc_trim``; elsewhere
    nothing happens). A page both processes hold is copied when either writes it, and the parent writes its free
    memory again for its next arrays while the worker runs; given back by the worker, such a page is the parent's alone
    and is not copied. In a 10^5-reading diagnosis (41 sets of fits) the parent spent 0.5-1 s less in the system
    (1.9-2.1 s instead of 2.5-2.9 s), its workers 0.2 s less."""
    import ctypes  # here: only a forked worker needs it

    trim = getattr(ctypes.CDLL(None), "malloc_trim", None)
    if trim is not None:
        trim(0)


def _run_share(*_: object) -> dict[int, bytes | None]:
    """The items this worker took while any were left (``_Share``), each result pickled; None for one that cannot be
    (an instance of a class made at run time and not shared): the parent then works that item itself."""
    assert _job is not None, "a worker inherits its job from the fork"
    results: dict[int, bytes | None] = {}
    while (index := _job.share.take()) is not None:
        result = _job.work(_job.items[index])
        out = io.BytesIO()
        try:
            _Dumper(out, _job.shared).dump(result)
        except (pickle.PicklingError, AttributeError, TypeError):
            results[index] = None
            continue
        results[index] = out.getvalue()
    return results


class _Dumper(pickle.Pickler):
    """Pickles a result, writing an object shared with the parent as its identity there (the same before the fork)."""

    def __init__(self, file: io.BytesIO, shared: dict[int, object]) -> None:
        super().__init__(file, pickle.HIGHEST_PROTOCOL)
        self.shared = shared

    def persistent_id(self, obj: object) -> int | None:
        key = id(obj)
        return key if key in self.shared and self.shared[key] is obj else None


class _Loader(pickle.Unpickler):
    """Unpickles a result, an identity written by ``_Dumper`` becoming the parent's own object."""

    def __init__(self, file: io.BytesIO, shared: dict[int, object]) -> None:
        super().__init__(file)
        self.shared = shared

    def persistent_load(self, pid: Any) -> object:
        return self.shared[pid]
