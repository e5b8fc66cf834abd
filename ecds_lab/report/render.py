"""Render the report's figures, in worker processes where the platform can fork.

Drawing with matplotlib is most of the time a report takes besides the diagnosis, and the
figures do not depend on each other. A section asks for a figure with ``Plot`` (the drawing
function, its arguments and a caption); ``start`` forks workers that inherit the plots (so
nothing but the finished PNG bytes crosses a process boundary) and returns at once, so the
caller can run the diagnosis meanwhile. Where ``fork`` is not available, or one worker is
asked for, the figures are drawn in this process when their results are collected.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ecds_lab.forked import can_fork, cpus
from ecds_lab.report.canvas import Png, styled, warm_up

_PENDING: list[Plot] = []


@dataclass
class Plot:
    """A figure to draw: ``draw(*args, **kwargs)`` returns its PNG; ``caption`` goes below it."""

    draw: Callable[..., Png]
    args: tuple[Any, ...]
    caption: str
    kwargs: dict[str, Any] = field(default_factory=dict)

    def render(self) -> Png:
        return self.draw(*self.args, **self.kwargs)


def _render_pending(index: int) -> Png:
    return _PENDING[index].render()


def default_workers(busy: int = 0) -> int:
    """Processes to draw with: the CPUs this process may use, less ``busy`` kept for other work, at least 1."""
    return max(1, cpus() - busy)


class Rendering:
    """Figures being drawn; ``results`` waits for them and returns the PNGs in order.

    Use it as a context manager, so the workers are stopped whatever happens meanwhile. One worker is forked only
    ``alongside`` other work of this process (the diagnosis): otherwise this process draws, as fast.
    """

    def __init__(self, plots: list[Plot], workers: int, alongside: bool = False) -> None:
        global _PENDING
        self.plots = plots
        self._pool = None
        self._async = None
        forked = workers > 1 or (alongside and workers == 1)
        if forked and len(plots) > (0 if alongside else 1) and can_fork():
            styled(warm_up)()
            _PENDING = plots  # the forked workers inherit this list
            try:
                self._pool = multiprocessing.get_context("fork").Pool(min(workers, len(plots)))
                self._async = self._pool.map_async(_render_pending, range(len(plots)), chunksize=1)
            except OSError:  # no processes to be had: draw here instead
                self.close()
            finally:
                _PENDING = []

    def results(self) -> list[Png]:
        if self._pool is None or self._async is None:
            return [plot.render() for plot in self.plots]
        try:
            return self._async.get()
        finally:
            self._pool.close()
            self._pool.join()
            self._pool = None

    def close(self) -> None:
        """Stop the workers (if still drawing, their figures are dropped)."""
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None

    def __enter__(self) -> Rendering:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def start(plots: list[Plot], workers: int | None = None, alongside: bool = False) -> Rendering:
    """Begin drawing ``plots`` with ``workers`` processes (default: every CPU); ``alongside``: this process works
    on something else meanwhile, so even one worker draws in a process of its own."""
    return Rendering(plots, default_workers() if workers is None else workers, alongside)
