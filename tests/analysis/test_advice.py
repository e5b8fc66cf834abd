"""The second frequency a one-frequency campaign is advised (``advice.another_frequency``): the paper's other one on
a non-magnetic plate, and on steel one at which its screening depth's law holds, never 500 Hz (docs/physics.md,
"A magnetic plate")."""

from __future__ import annotations

import dataclasses

import pytest

from ecds_lab.analysis.diagnosis.advice import Design, another_frequency
from ecds_lab.data.sensor import SensorConfig

AT_15_KHZ = Design(frequencies=1, frequencies_target_hot=1, directions=2, target_span_k=50.0, coil_span_k=0.0,
                   hold_s=0.0, finest_step_mm=10.0, present_hz=(15000.0,))


@pytest.mark.parametrize("target", ["copper", "aluminium", "brass"])
def test_a_non_magnetic_plate_measured_at_15_khz_is_advised_500_hz(target):
    assert another_frequency(AT_15_KHZ, SensorConfig(target=target)).startswith("measure at 500 Hz as well")


def test_a_steel_plate_measured_at_15_khz_is_advised_a_higher_frequency_not_500_hz():
    text = another_frequency(AT_15_KHZ, SensorConfig(target="steel"))
    assert text.startswith("measure at 50000 Hz as well"), text
    assert "from about 13 kHz up" in text, text


def test_a_steel_plate_measured_below_its_laws_range_is_advised_15_khz():
    at_500_hz = dataclasses.replace(AT_15_KHZ, present_hz=(500.0,))
    assert another_frequency(at_500_hz, SensorConfig(target="steel")).startswith("measure at 15000 Hz as well")


def test_a_coil_that_resonates_lower_is_advised_a_lower_second_frequency_on_steel():
    """A larger parallel capacitance (200 pF: the coil resonates at 47 kHz) keeps the advice below 0.6 of it."""
    text = another_frequency(AT_15_KHZ, SensorConfig(target="steel", capacitance_f=200e-12))
    assert text.startswith("measure at 20000 Hz as well"), text
