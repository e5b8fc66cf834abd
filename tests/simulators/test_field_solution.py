"""The Dodd & Deeds integral against independent references: quadrature, image method, Maxwell's filaments."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import j1

from ecds_lab.simulators.physics.coil import CoilSettings
from ecds_lab.simulators.physics.field_sensor import FieldSensor
from ecds_lab.simulators.physics.field_solution import CoilKernel, Winding, bessel_moment, kernel, reflection
from ecds_lab.simulators.physics.filaments import image_mutual, self_inductance
from ecds_lab.simulators.physics.plate import Plate, PlateSettings

PAPER_COIL = Winding(0.055, 0.075, 0.003, 500)


@pytest.mark.parametrize("u", [0.3, 4.0, 40.0, 400.0])
def test_struve_closed_form_matches_quadrature(u):
    expected, _ = quad(lambda t: t * j1(t), 0.0, u, limit=1000)
    assert bessel_moment(np.array([u]))[0] == pytest.approx(expected, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("x_m", [0.020, 0.050, 0.100])
def test_perfect_conductor_limit_equals_the_image_method(x_m):
    """phi = -1: dL = -M(coil, its mirror image), M from Maxwell's formula on a fine filament grid."""
    field = kernel(PAPER_COIL).perfect_conductor_delta_l(x_m)
    image = -image_mutual(PAPER_COIL, x_m, 60, 9)
    assert field == pytest.approx(image, rel=5e-3)
    assert field == pytest.approx(image, rel=1e-4)  # in fact far closer than the 0.5 %


def test_coil_in_air_equals_maxwell_filament_sum():
    field = kernel(PAPER_COIL).air_inductance_h
    filaments = self_inductance(PAPER_COIL, 60, 9)
    assert field == pytest.approx(filaments, rel=5e-3)
    assert 0.050 < field < 0.060  # the paper's coil: L ~ 57 mH measured at 15 kHz (with its C)


def test_huge_conductivity_tends_to_the_perfect_conductor():
    k = kernel(PAPER_COIL)
    phi = reflection(k.a, 2 * math.pi * 15e3, 1e12, 1.0, 5e-3)
    assert k.reflected(0.03, phi).real == pytest.approx(k.perfect_conductor_delta_l(0.03), rel=1e-3)


def test_non_conducting_magnetic_half_space_reflects_mu_ratio():
    a = np.linspace(1.0, 500.0, 7)
    assert np.allclose(reflection(a, 1e4, 0.0, 100.0, math.inf), 99.0 / 101.0)


def test_thick_plate_tends_to_the_half_space():
    a = np.linspace(1.0, 500.0, 7)
    omega = 2 * math.pi * 15e3
    assert np.allclose(reflection(a, omega, 58e6, 1.0, 0.05), reflection(a, omega, 58e6, 1.0, math.inf), atol=1e-9)


def test_scaled_kernel_equals_the_kernel_of_the_expanded_coil():
    """The expansion shortcut dZ(s) = s dZ(x/s, phi(a/s)) against a kernel built for the expanded winding."""
    s = 1.002
    grown = Winding(0.055 * s, 0.075 * s, 0.003 * s, 500)
    base, direct = CoilKernel(PAPER_COIL), CoilKernel(grown)
    omega = 2 * math.pi * 500
    shortcut = base.reflected(0.03, reflection(base.a / s, omega, 58e6, 1.0, 5e-3), scale=s)
    exact = direct.reflected(0.03, reflection(direct.a, omega, 58e6, 1.0, 5e-3))
    assert shortcut == pytest.approx(exact, rel=1e-9)
    assert direct.air_inductance_h == pytest.approx(s * base.air_inductance_h, rel=1e-9)


def test_truncated_grid_in_the_lab_matches_the_full_integral():
    sensor = FieldSensor(CoilSettings(), Plate(PlateSettings(), "copper"))
    omega = 2 * math.pi * 15e3
    for x in (0.02, 0.1):
        full = sensor.kernel.reflected(x, reflection(sensor.kernel.a, omega, 58e6, 1.0, 5e-3))
        assert sensor.plate_inductance(omega, x, 20.0, 20.0, 1.0) == pytest.approx(full, rel=1e-9)


def test_conducting_plate_adds_loss_and_lowers_l():
    k = kernel(PAPER_COIL)
    z = k.reflected(0.03, reflection(k.a, 2 * math.pi * 500, 58e6, 1.0, 5e-3))
    assert z.real < 0  # L falls
    assert -2 * math.pi * 500 * z.imag > 0  # R rises (dR = -w Im)
