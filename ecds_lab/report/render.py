"""Render the report's figures, in worker processes where the platform can fork.

Drawing with matplotlib is most of the time a report takes besides the diagnosis, and the
figures do not depend on each other. A section asks for a figure with ``Plot`` (the drawing
function, its arguments and a caption); ``start`` forks workers that inherit the plots (so
nothing but the finished PNG bytes crosses a process boundary) and returns at once, so the
caller can run the diagnosis meanwhile. Where ``fork`` is not available, or one worker is
asked for, the figures are drawn in this process when their results are collected; so are those of a worker that
died (killed, out of memory), rather than waited for.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any

from ecds_lab.forked import can_fork, cpus, stop, worker_pool
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
        self._pool: ProcessPoolExecutor | None = None
        self._drawn: list[Future[Png]] = []
        forked = workers > 1 or (alongside and workers == 1)
        if forked and len(plots) > (0 if alongside else 1) and can_fork():
            styled(warm_up)()
            _PENDING = plots  # the workers, forked at the first submission, inherit this list
            try:
                self._pool = worker_pool(min(workers, len(plots)))
                self._drawn = [self._pool.submit(_render_pending, index) for index in range(len(plots))]
            except (OSError, BrokenProcessPool):  # no processes to be had: draw here instead
                self.close()
            finally:
                _PENDING = []

    def results(self) -> list[Png]:
        if self._pool is None:
            return [plot.render() for plot in self.plots]
        try:
            return [self._collected(plot, drawn) for plot, drawn in zip(self.plots, self._drawn, strict=True)]
        finally:
            self.close()

    @staticmethod
    def _collected(plot: Plot, drawn: Future[Png]) -> Png:
        """A worker's figure; drawn here if the worker died (its error, if drawing it failed)."""
        try:
            return drawn.result()
        except BrokenProcessPool:
            return plot.render()

    def close(self) -> None:
        """Stop the workers (if still drawing, their figures are dropped)."""
        if self._pool is not None:
            stop(self._pool)
            self._pool, self._drawn = None, []

    def __enter__(self) -> Rendering:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def start(plots: list[Plot], workers: int | None = None, alongside: bool = False) -> Rendering:
    """Begin drawing ``plots`` with ``workers`` processes (default: every CPU); ``alongside``: this process works
    on something else meanwhile, so even one worker draws in a process of its own."""
    return Rendering(plots, default_workers() if workers is None else workers, alongside)
