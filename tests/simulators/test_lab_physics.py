"""The simulated lab against docs/physics.md, measured through the real drivers and transports."""

from __future__ import annotations

import numpy as np
import pytest

POSITIONS_MM = np.arange(20.0, 101.0, 10.0)


def inductance_mh(station, frequency_hz: float) -> float:
    station.bridge.set_frequency(frequency_hz)
    return station.bridge.measure().main * 1e3


def sweep_mh(station, frequency_hz: float) -> np.ndarray:
    values = []
    for x in POSITIONS_MM:
        station.slide.move_to(x * 1e-3)
        values.append(inductance_mh(station, frequency_hz))
    return np.array(values)


def test_coil_in_air_is_about_57_mh(open_sim_station):
    station = open_sim_station(target_present=False)
    for frequency in (500, 15000):
        assert inductance_mh(station, frequency) == pytest.approx(57.0, rel=0.05)


@pytest.mark.parametrize("frequency", [500, 15000])
def test_copper_target_l_rises_monotonically_toward_the_air_value(open_sim_station, frequency):
    air = inductance_mh(open_sim_station(target_present=False), frequency)
    values = sweep_mh(open_sim_station(), frequency)
    assert np.all(np.diff(values) > 0), values
    assert values[-1] < air
    assert air - values[-1] < 0.1 * (air - values[0])  # at 100 mm most of the way back to the air coil


def test_change_is_larger_at_15_khz_than_500_hz_and_for_copper_than_steel(open_sim_station):
    def change(material: str, frequency: float) -> float:
        values = sweep_mh(open_sim_station(sensor={"target": material}), frequency)
        return values[-1] - values[0]

    copper_15k, copper_500 = change("copper", 15000), change("copper", 500)
    steel_15k = change("steel", 15000)
    assert copper_15k > 3 * copper_500 > 0
    assert copper_15k > 3 * steel_15k > 0



@pytest.mark.parametrize("physics", ["ecm", "field"])
def test_aluminium_target_sweeps_through_the_emulators(open_sim_station, physics):
    """An aluminium plate (sensor target: aluminium) screens less than copper at 500 Hz (it conducts 65 % as well)."""
    air = inductance_mh(open_sim_station(physics=physics, sensor={"target": "aluminium"}, target_present=False), 500)
    aluminium = sweep_mh(open_sim_station(physics=physics, sensor={"target": "aluminium"}), 500)
    copper = sweep_mh(open_sim_station(physics=physics), 500)
    assert np.all(np.diff(aluminium) > 0), aluminium
    assert aluminium[-1] < air
    assert 0 < aluminium[-1] - aluminium[0] < copper[-1] - copper[0]

def series_branch(readings, frequency_hz: float, sensor) -> complex:
    """Mean measured Z with the coil's known parallel C and loss removed (the ECM's series branch)."""
    omega = 2 * np.pi * frequency_hz
    z = np.mean([complex(r.secondary, omega * r.main) for r in readings])
    return 1 / (1 / z - 1j * omega * sensor.capacitance_f - 1 / sensor.parallel_resistance_ohm)


@pytest.mark.parametrize("material, tau_s, frequency", [("copper", 100e-6, 500), ("steel", 3e-6, 15000)])
def test_tau_t_derived_from_measurements_matches_the_configured_value(open_sim_station, material, tau_s, frequency):
    """Eq. (2)-(3): the target adds dL = -L k^2 f_T and dR = w^2 tau L k^2 / (1 + (w tau)^2), so tau_T = -dL/dR."""
    target = open_sim_station(sensor={"target": material}, averages=16)
    air = open_sim_station(sensor={"target": material}, target_present=False, averages=16)
    target.slide.move_to(0.020)
    target.bridge.set_frequency(frequency)
    air.bridge.set_frequency(frequency)
    sensor = target.lab.config.sensor
    near = series_branch([target.bridge.measure() for _ in range(10)], frequency, sensor)
    far = series_branch([air.bridge.measure() for _ in range(10)], frequency, sensor)
    omega = 2 * np.pi * frequency
    d_l, d_r = (near - far).imag / omega, (near - far).real
    assert -d_l / d_r == pytest.approx(tau_s, rel=0.03)
