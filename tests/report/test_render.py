"""Figures drawn in forked workers come back in order; a failing figure fails the report."""

from __future__ import annotations

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


@pytest.mark.parametrize("workers", [1, 3])
def test_figures_come_back_in_order_with_their_size(workers):
    with start([Plot(line, (n,), "") for n in range(4)], workers) as rendering:
        pngs = rendering.results()
    assert [p.alt for p in pngs] == ["line 0", "line 1", "line 2", "line 3"]
    assert [p.width for p in pngs] == [96, 192, 288, 384] and all(p.height == 96 for p in pngs)


def test_a_failing_figure_raises_its_error():
    with pytest.raises(ValueError, match="figure 1 cannot be drawn"):
        with start([Plot(line, (0,), ""), Plot(broken, (1,), "")], 2) as rendering:
            rendering.results()
