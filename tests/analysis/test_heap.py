"""Freed memory is kept for reuse on glibc (the fits' arrays are not faulted in anew per evaluation)."""

from __future__ import annotations

import platform

import pytest

from ecds_lab.analysis.heap import retain_freed_memory


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt thresholds are glibc's")
def test_glibc_takes_the_thresholds_once_per_process() -> None:
    assert retain_freed_memory()
    assert retain_freed_memory()  # again: already set, nothing changes
