"""``forked.each``: the same results as a loop, in order, shared with other processes only when allowed;
``each_beside``: a piece worked here meanwhile."""

from __future__ import annotations

import os
import signal
import time

import pytest

from ecds_lab import forked

pytestmark = pytest.mark.skipif(not forked.can_fork(), reason="this platform does not fork")


class Shared:
    """An object the caller owns (data, say), to which results refer."""


def test_without_leave_the_work_stays_in_this_process():
    assert forked.each(lambda item: (item, os.getpid()), [1, 2, 3]) == [(1, os.getpid()), (2, os.getpid()),
                                                                         (3, os.getpid())]


def slowly(item: int) -> tuple[int, int]:
    """The item squared and the process that worked it, after a pause that lets every process take items."""
    time.sleep(0.05)
    return item * item, os.getpid()


def test_allowed_the_items_are_shared_with_a_worker_and_come_back_in_order():
    with forked.allowed(2):
        results = forked.each(slowly, range(12))
    assert [square for square, _ in results] == [i * i for i in range(12)]
    assert len({pid for _, pid in results}) == 2  # this process and one worker: two CPUs
    assert os.getpid() in {pid for _, pid in results}


def test_each_process_takes_the_next_item_so_a_long_one_holds_up_nobody():
    """One long item: the other process works every short one meanwhile, instead of the half it was handed."""
    def work(item: int) -> int:
        time.sleep(1.0 if item == 0 else 0.05)
        return os.getpid()

    with forked.allowed(2):
        workers = forked.each(work, range(9))
    assert workers[1:] == [workers[1]] * 8 and workers[0] != workers[1]


def test_one_item_is_worked_here_even_when_allowed():
    with forked.allowed(2):
        assert forked.each(lambda item: os.getpid(), ["only"]) == [os.getpid()]


def test_allowed_restores_what_was_allowed_before():
    with forked.allowed(2):
        with forked.allowed(1):
            assert forked.each(slowly, range(6)) == [(i * i, os.getpid()) for i in range(6)]
        assert len({pid for _, pid in forked.each(slowly, range(6))}) == 2
    assert forked.each(slowly, range(6)) == [(i * i, os.getpid()) for i in range(6)]


def test_a_shared_object_comes_back_as_itself_others_from_a_worker_as_copies():
    data, other = Shared(), Shared()
    with forked.allowed(2):
        results = forked.each(lambda item: {"data": data, "other": other, "new": Shared(), "none": None,
                                            "by": slowly(item)[1]}, range(6), shared=(data,))
    assert all(result["data"] is data for result in results)
    from_workers = [result for result in results if result["by"] != os.getpid()]
    assert from_workers and all(result["other"] is not other and isinstance(result["other"], Shared)
                                for result in from_workers)
    assert all(result["other"] is other for result in results if result["by"] == os.getpid())
    assert all(result["none"] is None for result in results)


def test_a_worker_works_alone_and_so_does_this_process_on_its_share():
    with forked.allowed(2):
        results = forked.each(lambda item: (slowly(item)[1], forked.each(lambda inner: os.getpid(), [1, 2])),
                              range(6))
    assert all(inner == [worker, worker] for worker, inner in results)
    assert len({worker for worker, _ in results}) == 2


def test_a_failure_in_a_worker_is_raised_here():
    def work(item: int) -> int:
        if item == 2:
            raise ValueError(f"item {item} is bad")
        return item

    with forked.allowed(2), pytest.raises(ValueError, match="item 2 is bad"):
        forked.each(work, [1, 2, 3])


def test_when_a_worker_dies_the_items_are_worked_here():
    here = os.getpid()

    def work(item: int) -> tuple[int, bool]:
        if item == 1 and os.getpid() != here:
            os.kill(os.getpid(), signal.SIGKILL)  # as the out-of-memory killer would
        return item, os.getpid() == here

    with forked.allowed(2):
        assert forked.each(work, [0, 1, 2]) == [(0, True), (1, True), (2, True)]


def test_beside_the_workers_a_piece_is_worked_here_meanwhile_then_its_share_of_the_items():
    def long_piece() -> int:
        time.sleep(0.5)
        return os.getpid()

    with forked.allowed(2):
        here, results = forked.each_beside(long_piece, slowly, range(12))
    assert here == os.getpid()
    assert [square for square, _ in results] == [i * i for i in range(12)]
    workers = [pid for _, pid in results]
    assert workers[0] != os.getpid()  # taken by the worker while the piece was worked here
    assert os.getpid() in workers[1:]  # what was left once it was done is shared


def test_in_one_process_the_piece_beside_comes_first_then_the_items():
    order: list[object] = []
    here, results = forked.each_beside(lambda: order.append("here") or "done", lambda item: order.append(item) or item,
                                       [1, 2])
    assert (here, results, order) == ("done", [1, 2], ["here", 1, 2])


def test_a_failure_of_the_piece_beside_ends_the_workers_and_is_raised_here():
    def failing() -> None:
        raise KeyboardInterrupt  # as Ctrl-C would, while the workers work

    def slow(item: int) -> int:
        time.sleep(30)
        return item

    started = time.monotonic()
    with forked.allowed(2), pytest.raises(KeyboardInterrupt):
        forked.each_beside(failing, slow, [1, 2])
    assert time.monotonic() - started < 10


def test_a_set_larger_than_a_pipe_holds_numbers_for_is_worked_here(monkeypatch):
    """Each item's number waits in a pipe, written before the workers are forked (``forked._Share``); a set with more
    items than the pipe holds is worked in this process alone, rather than waiting on a full pipe."""
    monkeypatch.setattr(forked, "SHARED_ITEMS", 3)
    with forked.allowed(2):
        assert forked.each(slowly, range(4)) == [(i * i, os.getpid()) for i in range(4)]
        assert len({pid for _, pid in forked.each(slowly, range(3))}) == 2


def test_a_worker_gives_back_the_free_memory_it_inherited_wherever_it_runs():
    """``_give_back_free_memory`` (glibc's malloc_trim, nothing where there is none) runs in this process without
    error, as every worker runs it first; the workers' results come back as before."""
    forked._give_back_free_memory()
    with forked.allowed(2):
        assert forked.each(lambda item: item * 2, [1, 2, 3]) == [2, 4, 6]
