"""Named model parameters: value, bounds, unit, prior scale, fixed flag, and their internal scaling.

The fit works on scaled offsets ``theta = (value - start) / prior_scale`` so every free
parameter is of order one, whatever its unit (henry, 1/K^2, farad...).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Parameter:
    """One model parameter; ``prior_scale`` is the size of a plausible change (sets the fit's scaling)."""

    name: str
    value: float
    lower: float = -math.inf
    upper: float = math.inf
    unit: str = ""
    description: str = ""
    prior_scale: float = 1.0
    fixed: bool = False

    def __post_init__(self) -> None:
        if not self.lower <= self.upper:
            raise ValueError(f"parameter {self.name}: lower bound {self.lower} > upper bound {self.upper}")
        if not self.prior_scale > 0:
            raise ValueError(f"parameter {self.name}: prior_scale must be > 0, got {self.prior_scale}")

    def with_value(self, value: float) -> Parameter:
        """The same parameter at another value, clipped into its bounds."""
        return replace(self, value=float(min(max(value, self.lower), self.upper)))

    def fix(self, value: float | None = None) -> Parameter:
        """The parameter held constant (at ``value`` if given)."""
        return replace(self, value=self.value if value is None else float(value), fixed=True)


def check_unique(parameters: Iterable[Parameter]) -> None:
    """Raise if two parameters share a name (two model parts claiming the same quantity)."""
    seen: set[str] = set()
    for p in parameters:
        if p.name in seen:
            raise ValueError(f"parameter name {p.name!r} is defined twice")
        seen.add(p.name)


def values_of(parameters: Iterable[Parameter]) -> dict[str, float]:
    """Name -> value mapping, what the model evaluates."""
    return {p.name: p.value for p in parameters}


def update(parameters: Sequence[Parameter], values: Mapping[str, float] | None = None,
           fixed: Mapping[str, float] | None = None) -> list[Parameter]:
    """New start values and newly fixed parameters by name; unknown names are an error."""
    names = {p.name for p in parameters}
    unknown = (set(values or {}) | set(fixed or {})) - names
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; the model has {sorted(names)}")
    out = []
    for p in parameters:
        if fixed and p.name in fixed:
            p = p.fix(fixed[p.name])
        elif values and p.name in values:
            p = p.with_value(values[p.name])
        out.append(p)
    return out


class Scaling:
    """Maps the free parameters to the fit's scaled vector theta and back."""

    def __init__(self, parameters: Sequence[Parameter]) -> None:
        self.parameters = list(parameters)
        self.free = [p for p in self.parameters if not p.fixed]
        self.names = [p.name for p in self.free]
        self.start = np.array([p.value for p in self.free])
        self.scale = np.array([p.prior_scale for p in self.free])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of theta."""
        lower = np.array([p.lower for p in self.free])
        upper = np.array([p.upper for p in self.free])
        return (lower - self.start) / self.scale, (upper - self.start) / self.scale

    def values(self, theta: np.ndarray) -> dict[str, float]:
        """All parameter values (fixed ones included) for a theta."""
        out = values_of(self.parameters)
        out.update(zip(self.names, (self.start + self.scale * np.asarray(theta)).tolist(), strict=True))
        return out

    def theta(self, values: Mapping[str, float]) -> np.ndarray:
        """Theta of given values (the inverse of ``values``)."""
        return (np.array([values[n] for n in self.names]) - self.start) / self.scale
