"""The sensor model reproduces the simulated lab's physics and exposes named parts for effects."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model import effects as effects_module
from ecds_lab.model.effects import EFFECT_NAMES, Effect, EffectRegistry, library, make_effect
from ecds_lab.model.parameters import Parameter, values_of
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.simulators.campaign import move_to
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import BOX_HEATER_OUTPUT, TARGET_HEATER_OUTPUT, SimulatedLab


def _lab_states(config: LabConfig) -> tuple[Measurements, np.ndarray]:
    """Noise-free readings of the lab over distances, heated coil and target, and the coil in air."""
    lab = SimulatedLab(config)
    rows, z_all = [], []
    for box_v, target_v in ((0.0, 0.0), (25.0, 0.0), (0.0, 28.0)):
        lab.set_supply(BOX_HEATER_OUTPUT, voltage_v=box_v, current_limit_a=10.0, on=box_v > 0)
        lab.set_supply(TARGET_HEATER_OUTPUT, voltage_v=target_v, current_limit_a=10.0, on=target_v > 0)
        lab.clock.sleep(4000)
        for x_mm in (15.0, 20.0, 47.5, 100.0, math.inf):
            lab.config.target_present = math.isfinite(x_mm)
            if lab.config.target_present:
                move_to(lab, x_mm)
            for f in (500.0, 15000.0, 40000.0):
                z = lab.coil_impedance(f)
                z_all.append(z)
                rows.append((lab.clock.now(), x_mm * 1e-3, f, lab.temperature_c("coil"),
                             lab.temperature_c("target"), z.imag / (2 * math.pi * f), z.real))
        lab.config.target_present = True
    return Measurements(*np.array(rows).T), np.array(z_all)


@pytest.mark.parametrize("former", ["fired_clay", "gypsum"])
def test_model_reproduces_the_simulated_coil_impedance(former):
    config = LabConfig(sensor=SensorConfig(former=former), beta_per_k2=3e-8)
    data, z = _lab_states(config)
    model = SensorModel(config.sensor)
    p = values_of(model.parameters()) | {"alpha": config.alpha, "beta": config.beta_per_k2, "tau_t": config.tau_t}
    assert data.t_coil_c.max() - data.t_coil_c.min() > 50
    # Independent implementations of the same equations (the model tabulates k(x), the lab's ECM sums
    # Maxwell's filaments at each x): equal to far below the bridge's ppm-level noise.
    np.testing.assert_allclose(model.impedance(data, p), z, rtol=1e-7)
    np.testing.assert_allclose(model.predict(data, p), data.ls_h, rtol=1e-7)


def test_calibrated_coupling_follows_eq5_and_vanishes_in_air():
    model = SensorModel()
    x = np.array([0.02, 0.05, np.inf])
    p = {"p1": 0.003, "p2": 1.2, "p3": 0.9, "p4": 0.01}
    k_hat = model.coupling_hat(x, p)
    expected = 0.9 * model.coupling((x[:2] - 0.003) / 1.2) + 0.01
    np.testing.assert_allclose(k_hat[:2], expected)
    assert k_hat[2] == 0.0


def test_parallel_capacitance_raises_the_apparent_inductance_with_frequency():
    model = SensorModel()
    n = 2
    data = Measurements(np.arange(n, dtype=float), np.full(n, np.inf), np.array([500.0, 15000.0]),
                        np.full(n, 20.0), np.full(n, 20.0), np.ones(n), np.ones(n))
    p = values_of(model.parameters()) | {"R_p": np.inf}
    ls = model.predict(data, p)
    omega, r0 = 2 * np.pi * data.freq_hz, model.sensor.resistance_ohm
    # (R + jwL) || C far below resonance: Ls ~ L (1 + w^2 L C) - R^2 C
    expected = omega**2 * p["L0"] * p["C_p"] - r0**2 * p["C_p"] / p["L0"]
    np.testing.assert_allclose(ls / p["L0"] - 1, expected, rtol=0.03)
    lossy = model.predict(data, values_of(model.parameters()))
    assert lossy[0] < ls[0]  # the former's loss lowers the apparent L most where R/(wL) is largest


class _Shift(Effect):
    """Test effect: the distance shifts with the direction of approach (like slide backlash)."""

    name = "test_shift"

    def parameters(self) -> list[Parameter]:
        return [Parameter("shift", 20e-6, -1e-3, 1e-3, "m", "half backlash", 10e-6)]

    def effective_distance(self, x_m, data, p):
        return x_m - data.direction * p["shift"]


class _Damp(Effect):
    """Test effect on later stages: tau from the effective target temperature, extra capacitance."""

    name = "test_damp"

    def parameters(self) -> list[Parameter]:
        return [Parameter("tau_tc", -0.004, -0.1, 0.1, "1/K", "", 1e-3),
                Parameter("extra_c", 5e-12, 0, 1e-9, "F", "", 1e-12)]

    def target_tau(self, tau_s, inputs, data, p):
        return tau_s * (1 + p["tau_tc"] * (inputs.t_target_c - 20.0))

    def coil_capacitance(self, c_f, inputs, data, p):
        return c_f + p["extra_c"]


@pytest.fixture
def registered():
    """A registry of the library's effects and two of the test's own (the library's own is not touched)."""
    return library().with_effects(_Shift, _Damp)


def _sweep_rows() -> Measurements:
    x = np.array([0.02, 0.04, 0.06, 0.04, 0.02])
    n = len(x)
    return Measurements(np.arange(n, dtype=float), x, np.full(n, 15000.0), np.full(n, 25.0),
                        np.array([20.0, 40.0, 60.0, 80.0, 100.0]), np.ones(n), np.ones(n))


def test_an_effect_registered_by_name_changes_its_stage(registered):
    data = _sweep_rows()
    base = SensorModel()
    shifted = SensorModel(effects=["test_shift"], registry=registered)
    p = values_of(shifted.parameters())
    assert [q.name for q in shifted.parameters()][-1] == "shift"
    expected = base.predict(data, p, x_m=data.x_m - data.direction * p["shift"])
    np.testing.assert_allclose(shifted.predict(data, p), expected, rtol=1e-14)
    assert not np.allclose(shifted.predict(data, p), base.predict(data, p), rtol=1e-7)


def test_later_hooks_see_effective_inputs(registered):
    data = _sweep_rows()
    model = SensorModel(effects=["test_damp"], registry=registered)
    p = values_of(model.parameters())
    z = model.impedance(data, p)
    tau = p["tau_t"] * (1 + p["tau_tc"] * (data.t_target_c - 20.0))
    base = SensorModel()
    manual = []
    for i in range(len(data)):
        q = dict(p, tau_t=tau[i], C_p=p["C_p"] + p["extra_c"])
        manual.append(base.impedance(data.select([i]), q)[0])
    np.testing.assert_allclose(z, manual, rtol=1e-13)


def test_effect_names_are_checked(registered):
    with pytest.raises(ValueError, match="test_damp"):
        make_effect("no_such_effect", SensorConfig(), registered)
    with pytest.raises(ValueError, match="listed twice"):
        SensorModel(effects=["test_shift", "test_shift"], registry=registered)
    assert "test_shift" not in library()  # the test's effects joined only the registry they were added to


def test_design_names_not_yet_implemented_say_so():
    missing = [n for n in EFFECT_NAMES if n not in library()]
    for name in missing:
        with pytest.raises(ValueError, match="known effect name but not implemented"):
            make_effect(name, SensorConfig())


def test_parameter_names_must_be_unique():
    class Clash(Effect):
        name = "clash"

        def parameters(self):
            return [Parameter("L0", 1.0)]

    with pytest.raises(ValueError, match="L0"):
        SensorModel(effects=[Clash(SensorConfig())])


def test_a_registry_enters_an_effect_once():
    registry = EffectRegistry()

    @effects_module.register
    class Demo(Effect):
        name = "demo"

    registry.add(Demo)
    registry.add(Demo)  # the same class again: no change
    assert registry.names() == ["demo"]
    assert isinstance(make_effect("demo", SensorConfig(), registry), Demo)
    assert "demo" not in library()

    class Other(Effect):
        name = "demo"

    with pytest.raises(ValueError, match="twice"):
        registry.add(Other)
    with pytest.raises(ValueError, match="no name"):
        effects_module.register(type("Nameless", (Effect,), {}))


def test_an_effects_key_and_size_parameters_default_to_all_its_own():
    """What the diagnosis must see determined (``key_names``) and what makes an effect's size (``size_names``): the
    declared ones, else every parameter of the effect, and the size the key ones."""
    sensor = SensorConfig()
    assert make_effect("slide_backlash", sensor).key_names() == ("backlash",)  # none declared: all its own
    screw = make_effect("slide_lead_screw", sensor)
    assert screw.key_names() == ("screw_sin", "screw_cos") == screw.size_names()
    bending = make_effect("target_bending", sensor)
    assert bending.size_names() == ("bending", "bending_quadratic") != bending.key_names()
