"""A property of the readings computed once for the readings last asked about (``analysis.per_readings``)."""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest

from ecds_lab.analysis.per_readings import per_readings
from ecds_lab.data.measurements import Measurements


def readings(n: int = 50) -> Measurements:
    """A sweep of ``n`` readings (fresh each call: another campaign object)."""
    ones = np.ones(n)
    return Measurements(time_s=np.arange(n, dtype=float), x_m=np.linspace(0.02, 0.1, n), freq_hz=500.0 * ones,
                        t_coil_c=21.0 * ones, t_target_c=21.0 * ones, ls_h=0.05 * ones, rs_ohm=50.0 * ones)


@pytest.fixture
def counted():
    calls = []

    @per_readings
    def doubled_x(data):
        calls.append(data)
        return data.x_m * 2

    return doubled_x, calls


def test_the_same_readings_get_the_same_answer_without_computing_it_again(counted):
    doubled_x, calls = counted
    data = readings()
    first = doubled_x(data)
    assert doubled_x(data) is first and len(calls) == 1
    np.testing.assert_array_equal(first, data.x_m * 2)


def test_other_readings_are_computed_anew_even_when_equal(counted):
    doubled_x, calls = counted
    data = readings()
    copy = data.select(np.ones(len(data), bool))  # equal values, another campaign object
    doubled_x(data)
    doubled_x(copy)
    doubled_x(data)
    assert len(calls) == 3


def test_the_shared_answer_is_read_only(counted):
    doubled_x, _ = counted
    answer = doubled_x(readings())
    with pytest.raises(ValueError):
        answer[0] = 0.0


def test_it_keeps_no_readings_alive(counted):
    doubled_x, calls = counted
    data = readings()
    doubled_x(data)
    calls.clear()
    held = weakref.ref(data)
    del data
    gc.collect()
    assert held() is None
