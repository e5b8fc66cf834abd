"""Coil temperature compensation, Eq. (4): characterisation in air and its effect on the position error."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.analysis.compensation import compare_compensation, fit_coil_temperature
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.simulators.campaign import coil_heated_sweeps, coil_heating, displacement_sweep
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

RISE_K = 100.0


@pytest.fixture(scope="module", params=["gypsum", "fired_clay"])
def heated_campaign(request):
    """Room sweep, coil heating in air to ambient + 100 K, then a sweep with the coil at that temperature."""
    config = LabConfig(sensor=SensorConfig(former=request.param), seed=8)
    lab = SimulatedLab(config)
    top = config.thermal.ambient_c + RISE_K
    room = displacement_sweep(lab, repeats=2, air_repeats=10)
    heating = coil_heating(lab, setpoints_c=np.linspace(config.thermal.ambient_c + 20, top, 5))
    hot = coil_heated_sweeps(lab, (top,))
    return config, room, heating, hot


def test_characterisation_recovers_eq4(heated_campaign):
    config, _, heating, _ = heated_campaign
    assert np.ptp(heating.t_coil_c) > 0.95 * RISE_K and heating.in_air.all()
    comp = fit_coil_temperature(heating, config.sensor)
    fit = comp.fit
    assert abs(comp.alpha_per_k - config.alpha) <= 3 * fit.stderr["alpha"]
    assert abs(comp.beta_per_k2 - config.beta_per_k2) <= 3 * fit.stderr["beta"]
    assert abs(comp.l0_h - config.sensor.inductance_h) <= 3 * fit.stderr["L0"]
    assert fit.stderr["alpha"] < 0.05 * config.alpha
    d = heating.t_coil_c - config.sensor.reference_temperature_c
    np.testing.assert_allclose(comp.factor(heating.t_coil_c), 1 + comp.alpha_per_k * d + comp.beta_per_k2 * d**2)


@pytest.mark.parametrize("frequency", [500.0, 15000.0])
def test_compensation_cuts_the_position_error_to_a_small_fraction(heated_campaign, frequency):
    config, room, heating, hot = heated_campaign
    assert hot.t_coil_c.min() > config.thermal.ambient_c + 0.99 * RISE_K
    comp = fit_coil_temperature(heating, config.sensor)
    result = compare_compensation(room.select(room.freq_hz == frequency), hot.select(hot.freq_hz == frequency),
                                  comp, config.sensor)
    assert result.uncompensated.max_abs_mm() > 1.0
    assert result.compensated.max_abs_mm() <= 0.15 * result.uncompensated.max_abs_mm()
    assert result.ratio <= 0.15


def test_compensating_readings_refers_them_to_the_reference_temperature(heated_campaign):
    config, _, heating, _ = heated_campaign
    comp = fit_coil_temperature(heating, config.sensor)
    low = heating.freq_hz == 500.0
    referred = comp.compensate(heating.ls_h[low], heating.t_coil_c[low])
    noise = config.noise.bridge_relative["slow"]
    assert np.std(heating.ls_h[low]) / np.mean(heating.ls_h[low]) > 10 * noise
    assert np.std(referred) / np.mean(referred) < 1.5 * noise


def test_characterisation_needs_the_coil_in_air(heated_campaign):
    _, _, _, hot = heated_campaign
    with pytest.raises(ValueError, match="in-air"):
        fit_coil_temperature(hot)
