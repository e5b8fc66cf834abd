"""The last result of a computation an effect repeats: a solver asks for an effect's value and then its derivatives
at the same parameters, and what both need (a spline through the knots, a drying integrated along the timeline) is
worked out once."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any, Generic, TypeVar

T = TypeVar("T")


class Remembered(Generic[T]):
    """The result of the last ``get`` and what it was made for: the same data (the same object, not equal
    readings) and an equal key (the parameters it depends on) give it back without working it out again. Pickled
    empty: a copy sent to another process works its results out there."""

    __slots__ = ("_data", "_key", "_made", "_value")

    def __init__(self) -> None:
        self._data: object = None
        self._key: Hashable = None
        self._made = False
        self._value: Any = None

    def get(self, data: object, key: Hashable, make: Callable[[], T]) -> T:
        """``make()``'s result for ``data`` and ``key``, made only if the last one was for other data or key."""
        if not (self._made and self._data is data and self._key == key):
            value = make()
            self._data, self._key, self._value, self._made = data, key, value, True
        return self._value

    def __reduce__(self) -> tuple[type[Remembered[T]], tuple[()]]:
        return type(self), ()
