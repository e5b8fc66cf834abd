"""Whether a target's temperatures can show a curvature: a third temperature inside the span, not a drift at one end."""

from __future__ import annotations

import numpy as np

#: Width (K) of one temperature level.
LEVEL_K = 5.0
#: A curvature needs this span (K).
MIN_CURVATURE_SPAN_K = 30.0
#: An inner level lies at least this share of the span from both ends.
INNER_SHARE = 0.25


def curvature_unseen(t_c: np.ndarray) -> str | None:
    """Why these temperatures cannot show a curvature in temperature, or None when they can: the span must reach
    MIN_CURVATURE_SPAN_K and a level of LEVEL_K must lie well inside it (INNER_SHARE of the span from both ends).
    A hot sweep drifting from 70 to 75 C beside a room-temperature one gives three 5 K levels but two
    temperatures: the curvature would be a second difference over 5 K against 50 K, traded with the slope."""
    if len(t_c) == 0:
        return "no temperatures"
    low, high = float(np.min(t_c)), float(np.max(t_c))
    span = high - low
    levels = np.unique(np.round(t_c / LEVEL_K)) * LEVEL_K
    inner = np.sum((levels - low >= INNER_SHARE * span) & (high - levels >= INNER_SHARE * span))
    if span < MIN_CURVATURE_SPAN_K or inner < 1:
        return (f"target temperature span {span:.1f} K with {int(inner)} level(s) of {LEVEL_K:g} K inside it (a "
                f"curvature needs {MIN_CURVATURE_SPAN_K:g} K and a level at least {INNER_SHARE:.0%} of the span "
                "from both ends)")
    return None
