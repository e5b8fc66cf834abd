"""``forked.each``: the same results as a loop, in order, from other processes only when allowed; ``each_beside``: a
piece worked here meanwhile."""

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


def test_allowed_the_items_are_worked_elsewhere_and_come_back_in_order():
    with forked.allowed(2):
        results = forked.each(lambda item: (item * item, os.getpid()), range(7))
    assert [square for square, _ in results] == [i * i for i in range(7)]
    assert os.getpid() not in {pid for _, pid in results}


def test_one_item_is_worked_here_even_when_allowed():
    with forked.allowed(2):
        assert forked.each(lambda item: os.getpid(), ["only"]) == [os.getpid()]


def test_allowed_restores_what_was_allowed_before():
    with forked.allowed(2):
        with forked.allowed(1):
            assert forked.each(lambda item: os.getpid(), [1, 2]) == [os.getpid()] * 2
        assert os.getpid() not in forked.each(lambda item: os.getpid(), [1, 2])
    assert forked.each(lambda item: os.getpid(), [1, 2]) == [os.getpid()] * 2


def test_a_shared_object_comes_back_as_itself_others_as_copies():
    data, other = Shared(), Shared()
    with forked.allowed(2):
        results = forked.each(lambda item: {"data": data, "other": other, "new": Shared(), "none": None},
                              [1, 2], shared=(data,))
    assert all(result["data"] is data for result in results)
    assert all(result["other"] is not other and isinstance(result["other"], Shared) for result in results)
    assert all(result["none"] is None for result in results)


def test_a_worker_works_alone():
    with forked.allowed(2):
        results = forked.each(lambda item: (os.getpid(), forked.each(lambda inner: os.getpid(), [1, 2])), [1, 2])
    assert all(inner == [worker, worker] for worker, inner in results)


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


def test_beside_the_workers_a_piece_is_worked_here_meanwhile():
    with forked.allowed(2):
        here, results = forked.each_beside(lambda: os.getpid(), lambda item: (item, os.getpid()), range(4))
    assert here == os.getpid()
    assert [item for item, _ in results] == [0, 1, 2, 3]
    assert os.getpid() not in {pid for _, pid in results}


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
