"""The operator's progress display: a bar of planned points on a terminal, nothing elsewhere."""

from __future__ import annotations

from tqdm import tqdm


class Progress:
    """Counts measured points and shows what the run is waiting for; silent when ``enabled`` is False."""

    def __init__(self, name: str, points_to_measure: int, *, enabled: bool) -> None:
        # tqdm turns itself off (disable=None) when its output is not a terminal
        self._bar = (tqdm(total=points_to_measure, unit="pt", desc=name, disable=None, dynamic_ncols=True)
                     if enabled else None)

    def point_measured(self) -> None:
        if self._bar is not None:
            self._bar.update(1)

    def note(self, text: str) -> None:
        """A short status beside the bar, e.g. a heater's temperature while the run waits on it."""
        if self._bar is not None:
            self._bar.set_postfix_str(text)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
