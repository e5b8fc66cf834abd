"""The FOPDT fit of a heater pulse, the SIMC gains it proposes, the PI loop's anti-windup, the gains' validation."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.config.loading import validate
from ecds_lab.config.station import LoopGains, StationConfig
from ecds_lab.errors import ConfigError, EcdsLabError
from ecds_lab.runner.heater_control import PowerLoop
from ecds_lab.runner.plant_identification import HeaterPlant, fit_pulse, simc_gains


def pulse_record(plant: HeaterPlant, power_w: float, on_s: float, off_s: float, end_s: float, noise_k: float = 0.02):
    t = np.arange(0.0, end_s, 10.0)
    rise = power_w * (plant.step_rise_k(t - on_s) - plant.step_rise_k(t - off_s))
    return t, 22.0 + rise + np.random.default_rng(3).normal(0.0, noise_k, t.size)


@pytest.mark.parametrize("plant", [HeaterPlant(1.0, 600.0, 30.0), HeaterPlant(3.0, 120.0, 20.0),
                                   HeaterPlant(1.0, 3000.0, 60.0), HeaterPlant(1.2, 900.0, 10.0, lag_s=120.0)])
def test_the_fit_recovers_the_initial_slope_and_the_gains_of_a_pulse(plant):
    on, power = 40.0, 22.0
    off = on + plant.dead_time_s + 3.0 * plant.tau_s / (plant.gain_k_per_w * power)  # about a 3 K rise
    t, temps = pulse_record(plant, power, on, off, off + 2 * (off - on))
    fitted = fit_pulse(t, temps, on_s=on, off_s=off, power_w=power)
    slope, fitted_slope = plant.gain_k_per_w / plant.tau_s, fitted.gain_k_per_w / fitted.tau_s
    if plant.lag_s == 0.0:  # one lag: its initial slope is K / tau
        assert fitted_slope == pytest.approx(slope, rel=0.2)
    proposed, ideal = (simc_gains(p, period_s=10.0, max_power_w=1000.0) for p in (fitted, plant))
    assert proposed.kp_w_per_k == pytest.approx(ideal.kp_w_per_k, rel=0.35)
    assert proposed.ti_s == pytest.approx(ideal.ti_s, rel=0.35)


def test_a_heater_that_does_not_heat_its_thermocouple_is_named():
    t = np.arange(0.0, 600.0, 10.0)
    with pytest.raises(EcdsLabError, match="did not rise"):
        fit_pulse(t, np.full(t.size, 22.0), on_s=40.0, off_s=300.0, power_w=20.0)


def test_simc_gains_follow_the_plant_and_stay_within_the_heater():
    gains = simc_gains(HeaterPlant(1.0, 600.0, 25.0), period_s=10.0, max_power_w=112.5)
    theta = 25.0 + 10.0  # dead time and one control period
    assert gains.kp_w_per_k == pytest.approx(600.0 / (3 * theta)) and gains.td_s == 0.0
    assert gains.ti_s == pytest.approx(min(600.0, 12 * theta))
    assert simc_gains(HeaterPlant(0.001, 600.0, 0.0), period_s=10.0, max_power_w=112.5).kp_w_per_k == 112.5


def test_a_second_lag_longer_than_the_dead_time_is_cancelled_by_a_derivative():
    plant = HeaterPlant(1.2, 4500.0, 20.0, lag_s=600.0)
    gains = simc_gains(plant, period_s=10.0, max_power_w=1000.0)
    theta, tc = 30.0, 60.0
    kc, ti, td = 4500.0 / (1.2 * (tc + theta)), 4 * (tc + theta), 600.0  # SIMC PID, series form
    assert gains.kp_w_per_k == pytest.approx(kc * (1 + td / ti))
    assert gains.ti_s == pytest.approx(ti + td) and gains.td_s == pytest.approx(ti * td / (ti + td))


def test_the_derivative_acts_on_the_measurement_not_on_a_setpoint_change():
    loop = PowerLoop(1000.0, LoopGains(kp_w_per_k=10.0, ti_s=1000.0, td_s=100.0))
    steady = loop.update(50.0, 40.0, 10.0)
    moved = loop.update(60.0, 40.0, 10.0)  # setpoint up 10 K, measurement unchanged: P and I only
    assert moved - steady == pytest.approx(10.0 * 10.0 + 10.0 * 20.0 * 10.0 / 1000.0)
    rising = loop.update(60.0, 41.0, 10.0)  # measurement rising 0.1 K/s: the derivative brakes
    assert loop.derivative_w < 0.0 and rising < moved


def test_a_loop_near_full_power_still_integrates_towards_its_setpoint():
    """Before: a large integral step that would saturate the output was refused whole, every period, so a loop
    that needed nearly full power sat below its setpoint for ever (127.3 C for 130 C)."""
    loop = PowerLoop(112.5, LoopGains(kp_w_per_k=40.0, ti_s=60.0))
    loop.integral_w = -3.0
    power = loop.update(130.0, 127.3, 10.0)
    assert loop.integral_w > -3.0 and power == pytest.approx(112.5)


def test_bad_gains_are_refused_naming_the_field():
    with pytest.raises(ConfigError, match=r"regulation\.target\.kp_w_per_k") as refused:
        validate("station.yaml", {"simulated": {}, "regulation": {"target": {"kp_w_per_k": -1}}}, StationConfig)
    assert len(str(refused.value).splitlines()) == 1
    with pytest.raises(ConfigError, match=r"regulation\.identify\.step_fraction"):
        validate("station.yaml", {"simulated": {}, "regulation": {"identify": {"step_fraction": 0.9}}}, StationConfig)
