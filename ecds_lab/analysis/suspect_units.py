"""Readings whose units look wrong for the data contract (docs/data-contract.md: °C, H), named before the analysis
reads them as physics: a CSV written in kelvin or in millihenry fits, and its figures would mean nothing.

These are notes, not errors: a coil far from the sensor described, or a furnace far hotter than this lab's, may be
real, so the analysis still runs and the note says what to check.
"""

from __future__ import annotations

import numpy as np

from ecds_lab.analysis.quantities import format_quantity
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig

#: A median temperature above this (°C) reads as kelvin sooner than as a lab's: room temperature is 293 K, and the
#: paper's formers are heated to 130 °C.
KELVIN_LIKE_C = 200.0
#: A median inductance this many times larger or smaller than the sensor's air-coil L reads as another unit (mH
#: written as H is 1000x), or as another coil than the sensor described; a target changes L by a few percent.
INDUCTANCE_FACTOR = 20.0


def unit_notes(data: Measurements, sensor: SensorConfig) -> list[str]:
    """What to check about the units of ``data``'s temperatures and inductance, given the sensor it is analysed as
    (empty when they look as the data contract says)."""
    notes = []
    for column in ("t_coil_c", "t_target_c"):
        values = getattr(data, column)
        values = values[np.isfinite(values)]
        if len(values) and float(np.median(values)) > KELVIN_LIKE_C:
            notes.append(f"{column} has a median of {float(np.median(values)):.1f} °C: temperatures are in °C "
                         "(the data contract); kelvin would read 273.15 higher")
    inductance = np.abs(data.ls_h[np.isfinite(data.ls_h)])
    if len(inductance):
        median = float(np.median(inductance))
        ratio = median / sensor.inductance_h
        if not 1 / INDUCTANCE_FACTOR <= ratio <= INDUCTANCE_FACTOR:
            notes.append(f"ls_h has a median of {format_quantity(median, 'H')}, {ratio:.3g}x the air-coil inductance "
                         f"of the sensor analysed ({sensor.name}: {format_quantity(sensor.inductance_h, 'H')}): "
                         "inductances are in henry (the data contract; values in mH read 1000x too large), or name "
                         "the coil measured with --sensor")
    return notes
