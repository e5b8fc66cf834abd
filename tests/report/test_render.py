"""Figures drawn in forked workers come back in order; a failing figure fails the report; the figures of a worker
that died are drawn here."""

from __future__ import annotations

import os
import signal

import pytest

from ecds_lab.report.canvas import Png, styled, subplots, to_png
from ecds_lab.report.render import Plot, start


@styled
def line(n: int) -> Png:
    figure, axes = subplots(1.0 + n, 1.0)
    axes[0, 0].plot([0, n], [0, 1])
    return to_png(figure, f"line {n}")


@styled
def broken(n: int) -> Png:
    raise ValueError(f"figure {n} cannot be drawn")


@pytest.mark.parametrize(("workers", "alongside"), [(1, False), (3, False), (1, True)])
def test_figures_come_back_in_order_with_their_size(workers, alongside):
    with start([Plot(line, (n,), "") for n in range(4)], workers, alongside) as rendering:
        pngs = rendering.results()
    assert [p.alt for p in pngs] == ["line 0", "line 1", "line 2", "line 3"]
    assert [p.width for p in pngs] == [96, 192, 288, 384] and all(p.height == 96 for p in pngs)


def test_a_failing_figure_raises_its_error():
    with pytest.raises(ValueError, match="figure 1 cannot be drawn"):
        with start([Plot(line, (0,), ""), Plot(broken, (1,), "")], 2) as rendering:
            rendering.results()


@pytest.mark.parametrize("alongside", [False, True])
def test_one_worker_draws_in_a_process_of_its_own_only_beside_other_work(alongside):
    """On two CPUs the report draws with one worker while the diagnosis runs in this process: that worker must be a
    process of its own (drawing in this process would wait for the diagnosis)."""
    drawn_in = []

    def where(n: int) -> Png:
        drawn_in.append(os.getpid())
        return line(n)

    with start([Plot(where, (n,), "") for n in range(2)], 1, alongside) as rendering:
        pngs = rendering.results()
    assert [p.alt for p in pngs] == ["line 0", "line 1"]
    # a forked worker appends to its own copy of the list: only figures drawn here are seen here
    assert drawn_in == ([] if alongside else [os.getpid()] * 2)


def test_the_figures_of_a_worker_that_died_are_drawn_here():
    here = os.getpid()

    def fatal(n: int) -> Png:
        if os.getpid() != here:
            os.kill(os.getpid(), signal.SIGKILL)  # as the out-of-memory killer would
        return line(n)

    with start([Plot(line, (0,), ""), Plot(fatal, (1,), ""), Plot(line, (2,), "")], 2) as rendering:
        pngs = rendering.results()
    assert [p.alt for p in pngs] == ["line 0", "line 1", "line 2"]
