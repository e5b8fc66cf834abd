"""Derivatives carried through the model (forward mode): each quantity's change per parameter, row by row.

A ``Tangent`` maps a parameter name to the derivative of one model quantity (one value per data row)
with respect to that parameter; a name that is absent has derivative zero. The sensor model carries one
tangent beside each quantity of its pipeline (``SensorModel.prediction_and_jacobian``), and each effect's
derivative hook (``Effect.d_effective_distance`` ...) maps the tangent of what it is given to the tangent of
what it returns: the chain rule for the quantity it changes plus its own partial derivatives.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

#: parameter name -> d quantity / d parameter at every row (absent: 0)
Tangent = dict[str, np.ndarray]


def scaled(tangent: Mapping[str, np.ndarray], factor: np.ndarray | float) -> Tangent:
    """The tangent of ``factor * q`` with ``factor`` held (d(f q) = f dq): every entry times ``factor``."""
    return {name: factor * values for name, values in tangent.items()}


def mapped(tangent: Mapping[str, np.ndarray], operator: Callable[[np.ndarray], np.ndarray]) -> Tangent:
    """The tangent of ``A q`` for a linear operator A along the rows (e.g. a first-order lag in time)."""
    return {name: operator(values) for name, values in tangent.items()}


def plus(tangent: Mapping[str, np.ndarray], *more: Mapping[str, np.ndarray | float]) -> Tangent:
    """The sum of tangents (entries of the same parameter added; scalars broadcast)."""
    out: Tangent = dict(tangent)
    for other in more:
        for name, values in other.items():
            out[name] = out[name] + values if name in out else np.asarray(values, float)
    return out


def chained(tangent: Mapping[str, np.ndarray], factor: np.ndarray | float,
            own: Mapping[str, np.ndarray | float]) -> Tangent:
    """The tangent of ``g(q, theta)``: ``dg/dq`` (``factor``) times q's tangent plus g's own partials ``own``."""
    return plus(scaled(tangent, factor), own)


def add_to(total: Tangent, tangent: Mapping[str, np.ndarray], factor: np.ndarray | float) -> None:
    """``total += factor * tangent``, in place (the sum a quantity's tangents make in a result)."""
    for name, values in tangent.items():
        term = factor * values
        if name in total:
            total[name] += term
        else:
            total[name] = term


@dataclass(frozen=True)
class InputTangents:
    """The tangents of ``Inputs``: effective distance and the two temperatures."""

    x_m: Tangent
    t_winding_c: Tangent
    t_target_c: Tangent
