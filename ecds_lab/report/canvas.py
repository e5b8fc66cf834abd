"""Figures for the report: a new matplotlib figure on the Agg canvas, in the report's style, and its PNG.

No pyplot: figures are plain ``matplotlib.figure.Figure`` objects with an Agg canvas, so
making a report touches no global plotting state and needs no display.
"""

from __future__ import annotations

import functools
import io
from dataclasses import dataclass
from typing import Any, Callable

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure

#: Pixels per inch of the embedded PNGs (sizes are given in inches).
DPI = 96

STYLE = {
    "font.size": 9.0,
    "axes.titlesize": 9.5,
    "axes.labelsize": 9.0,
    "legend.fontsize": 7.5,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
}


@dataclass
class Png:
    """An encoded figure: PNG bytes, pixel size, and the text that describes it."""

    data: bytes
    width: int
    height: int
    alt: str


def styled(draw: Callable[..., Png]) -> Callable[..., Png]:
    """Run a figure-drawing function with the report's matplotlib style in force."""

    @functools.wraps(draw)
    def wrapper(*args: Any, **kwargs: Any) -> Png:
        with matplotlib.rc_context(STYLE):
            return draw(*args, **kwargs)

    return wrapper


def subplots(width_in: float, height_in: float, rows: int = 1, cols: int = 1, *, layout: str | None = "constrained",
             **kwargs: Any) -> tuple[Figure, np.ndarray]:
    """A figure on an Agg canvas (constrained layout unless ``layout=None``) and a 2-D array of its axes."""
    figure = Figure(figsize=(width_in, height_in), dpi=DPI, layout=layout)
    FigureCanvasAgg(figure)
    return figure, figure.subplots(rows, cols, squeeze=False, **kwargs)


def to_png(figure: Figure, alt: str) -> Png:
    """Render to PNG bytes at the report's resolution (the figure's size in inches times DPI)."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI)
    width, height = (int(round(v)) for v in figure.get_size_inches() * DPI)
    figure.clear()
    return Png(buffer.getvalue(), width, height, alt)


def colormap(name: str) -> Colormap:
    """A registered matplotlib colour map by name."""
    return matplotlib.colormaps[name]


def colour_scale(norm: Normalize, cmap: Colormap) -> ScalarMappable:
    """A colour scale not tied to one plot, for a colour bar shared by several."""
    return ScalarMappable(norm=norm, cmap=cmap)
