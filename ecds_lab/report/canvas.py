"""Figures for the report: a new matplotlib figure on the Agg canvas, in the report's style, and its PNG.

No pyplot: figures are plain ``matplotlib.figure.Figure`` objects with an Agg canvas, so
making a report touches no global plotting state and needs no display.
"""

from __future__ import annotations

import functools
import io
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, ParamSpec, TypeVar

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType  # the rc keys as a Literal (matplotlib >= 3.8)

#: Pixels per inch of the embedded PNGs (sizes are given in inches).
DPI = 96

P = ParamSpec("P")
R = TypeVar("R")

STYLE: dict[RcKeyType, Any] = {
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


def styled(draw: Callable[P, R]) -> Callable[P, R]:
    """Run a figure-drawing function with the report's matplotlib style in force."""

    @functools.wraps(draw)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with matplotlib.rc_context(STYLE):
            return draw(*args, **kwargs)

    return wrapper


def subplots(width_in: float, height_in: float, rows: int = 1, cols: int = 1, *,
             layout: Literal["constrained", "compressed", "tight"] | None = "constrained",
             **kwargs: Any) -> tuple[Figure, np.ndarray]:
    """A figure on an Agg canvas (constrained layout unless ``layout=None``) and a 2-D array of its axes."""
    figure = Figure(figsize=(width_in, height_in), dpi=DPI, layout=layout)
    FigureCanvasAgg(figure)
    return figure, figure.subplots(rows, cols, squeeze=False, **kwargs)


def grid(panel_w_in: float, panel_h_in: float, rows: int, cols: int, *, left: float = 0.75, right: float = 0.2,
         bottom: float = 0.5, top: float = 0.3, gap_w: float = 0.9, gap_h: float = 0.75,
         key_w: float = 0.0, **kwargs: Any) -> tuple[Figure, np.ndarray, Axes | None]:
    """Panels of a fixed size with fixed margins (inches), no layout engine; a key axes on the right if ``key_w``.

    Much cheaper to draw than a constrained layout; the margins must leave room for the labels.
    """
    width = left + cols * panel_w_in + (cols - 1) * gap_w + right + key_w
    height = bottom + rows * panel_h_in + (rows - 1) * gap_h + top
    figure = Figure(figsize=(width, height), dpi=DPI)
    FigureCanvasAgg(figure)
    axes = figure.subplots(rows, cols, squeeze=False, gridspec_kw={
        "left": left / width, "right": (width - right - key_w) / width, "bottom": bottom / height,
        "top": (height - top) / height, "wspace": gap_w / panel_w_in, "hspace": gap_h / panel_h_in}, **kwargs)
    key = None
    if key_w:
        key = figure.add_axes(((width - key_w + 0.15) / width, bottom / height + 0.1, 0.14 / width,
                               (height - top - bottom) / height - 0.2))
    return figure, axes, key


def warm_up() -> None:
    """Draw a small figure once, so fonts and caches are loaded before workers fork and share them."""
    figure, axes = subplots(2.0, 1.5)
    axes[0, 0].plot([0, 1], [0, 1], "o-", label="µ ϑ Δ")
    axes[0, 0].set_xlabel("x (mm)")
    axes[0, 0].legend()
    to_png(figure, "warm-up")


def to_png(figure: Figure, alt: str) -> Png:
    """Render to PNG bytes at the report's resolution (the figure's size in inches times DPI)."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI)
    figure.clear()
    data = buffer.getvalue()
    width, height = struct.unpack(">II", data[16:24])  # the IHDR chunk follows the 8-byte signature
    return Png(data, width, height, alt)


def colormap(name: str) -> Colormap:
    """A registered matplotlib colour map by name."""
    return matplotlib.colormaps[name]


def colour_scale(norm: Normalize, cmap: Colormap) -> ScalarMappable:
    """A colour scale not tied to one plot, for a colour bar shared by several."""
    return ScalarMappable(norm=norm, cmap=cmap)
