"""Every library effect's plausible ranges (issue 23, class 4): inside its parameter bounds, so a fit beyond
the range can show it, for the sensors a YAML may describe (a small coil on a thin plate, the paper's
coil, a large coil with a large parallel capacitance)."""

from __future__ import annotations

import pytest

from ecds_lab.data.sensor import CoilGeometry, SensorConfig
from ecds_lab.model.effects import library

SENSORS = {
    "small coil, 1 mm plate": SensorConfig(coil=CoilGeometry(inner_radius_m=3e-3, outer_radius_m=6e-3, height_m=2e-3),
                                           target_thickness_m=1e-3, capacitance_f=5e-12),
    "the paper's coil": SensorConfig(),
    "large coil, 500 pF": SensorConfig(coil=CoilGeometry(inner_radius_m=0.12, outer_radius_m=0.15, height_m=8e-3),
                                       target_thickness_m=20e-3, capacitance_f=500e-12),
}


@pytest.mark.parametrize("sensor", SENSORS.values(), ids=SENSORS.keys())
def test_plausible_ranges_lie_inside_the_bounds_for_every_sensor(sensor):
    for name in library():
        effect = library().make(name, sensor)
        bounds = {p.name: (p.lower, p.upper) for p in effect.parameters()}
        for parameter, (low, high) in effect.plausible.items():
            lower, upper = bounds[parameter]
            assert lower <= low < high <= upper, (name, parameter)
            assert lower < low or upper > high, (name, parameter)  # room beyond the range on one side at least


def test_ranges_cover_thin_plates_and_small_coils():
    """The sizes the reasoning beside each range names: a 1 mm aluminium plate bows ~40 um/K; a small coil's
    tau_T at 20 mm is a third of its value at 60 mm (ln 1/3 = -1.1); a large coil's moisture may add its C_p."""
    effects = library()
    assert effects["target_bending"].plausible["bending"][1] >= 40e-6
    assert effects["tau_displacement"].plausible["tau_x_20mm"][0] <= -1.1
    large = effects.make("parasitic_capacitance", SENSORS["large coil, 500 pF"])
    assert large.plausible["moist_dC"][1] >= 500e-12
