"""A property of a campaign's readings computed once for the readings last asked about.

The diagnosis asks some questions of the same readings again and again (the states of a campaign, for the structure
each claim leaves; the states an effect does not act in): ``per_readings`` remembers a function's answer for the last
``Measurements`` it was given, by identity (held weakly, so it keeps no readings alive), and hands it out read-only,
since every caller shares it.
"""

from __future__ import annotations

import functools
import weakref
from collections.abc import Callable

import numpy as np

from ecds_lab.data.measurements import Measurements


def per_readings(function: Callable[[Measurements], np.ndarray]) -> Callable[[Measurements], np.ndarray]:
    """``function`` of the readings, computed again only for readings other than the last (see the module)."""
    last: tuple[weakref.ref[Measurements], np.ndarray] | None = None

    @functools.wraps(function)
    def remembered(data: Measurements) -> np.ndarray:
        nonlocal last
        held = last  # one read: a thread replacing it meanwhile leaves this pair whole
        if held is not None and held[0]() is data:
            return held[1]
        answer = function(data)
        answer.flags.writeable = False
        last = (weakref.ref(data), answer)
        return answer

    return remembered
