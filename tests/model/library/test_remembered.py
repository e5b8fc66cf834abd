"""``Remembered``: an effect's last intermediate, made again only for other data or another key."""

from __future__ import annotations

import pickle

from ecds_lab.model.library.remembered import Remembered


def test_the_last_result_is_given_back_for_the_same_data_and_an_equal_key_and_made_again_otherwise():
    made: list[tuple[str, int]] = []
    remembered: Remembered[int] = Remembered()
    data, other = object(), object()

    def get(source: object, key: int) -> int:
        return remembered.get(source, key, lambda: made.append((id(source), key)) or key * 10)

    assert [get(data, 1), get(data, 1), get(data, 2), get(data, 1), get(other, 1), get(other, 1)] == [10] * 2 + [
        20, 10, 10, 10]
    assert made == [(id(data), 1), (id(data), 2), (id(data), 1), (id(other), 1)]


def test_a_result_that_failed_is_not_remembered():
    remembered: Remembered[float] = Remembered()
    data = object()
    try:
        remembered.get(data, "k", lambda: 1 / 0)
    except ZeroDivisionError:
        pass
    assert remembered.get(data, "k", lambda: 2.0) == 2.0


def test_a_copy_for_another_process_is_sent_empty():
    remembered: Remembered[bytes] = Remembered()
    data = object()
    remembered.get(data, 1, lambda: b"x" * 10**6)
    copy = pickle.loads(pickle.dumps(remembered))
    assert len(pickle.dumps(remembered)) < 1000
    assert copy.get(data, 1, lambda: b"again") == b"again"
