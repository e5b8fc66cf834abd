"""Every analytic derivative of the model (baseline and each library effect) agrees with finite differences."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest

from ecds_lab import shipped
from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.station import StationConfig
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import load_sensor
from ecds_lab.model.effects import Effect, library
from ecds_lab.model.parameters import Parameter, values_of
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.model.tangents import chained
from ecds_lab.simulators import campaign

#: Agreement asked of every derivative (largest difference over the largest finite-difference value).
RELATIVE = 1e-5


@pytest.fixture(scope="module")
def station() -> StationConfig:
    return load_yaml_model(shipped.station("simulated_lab.yaml"), StationConfig)


@pytest.fixture(scope="module")
def data(station: StationConfig) -> Measurements:
    """The faithful lab's paper campaign on a 2 mm grid (fine enough for the lead screw), heating logged every 5 min:
    both directions, two frequencies, heated target and coil, ramps, the coil in air; two recordings joined."""
    assert station.simulated is not None
    parts = [campaign.paper_campaign(station.simulated.lab, seed=seed, positions_mm=np.linspace(20, 100, 41).tolist(),
                                     interval_s=300.0) for seed in (1, 2)]
    return Measurements.concatenate(parts)


def moved(parameters: list[Parameter], changes: Mapping[str, float] | None = None) -> dict[str, float]:
    """Every parameter a third of its prior scale off its start (inside its bounds), so no term vanishes."""
    p = values_of(parameters)
    for q in parameters:
        if q.name != "R_p":
            p[q.name] = min(max(q.value + 0.3 * q.prior_scale, q.lower), q.upper)
    p.update(changes or {})
    return p


def finite_difference(model: SensorModel, data: Measurements, p: dict[str, float], name: str,
                      step: float) -> np.ndarray:
    up, down = dict(p), dict(p)
    up[name] += step
    down[name] -= step
    return (model.predict(data, up) - model.predict(data, down)) / (2 * step)


def check(model: SensorModel, data: Measurements, p: dict[str, float], at_lower_bound: tuple[str, ...] = (),
          inert: tuple[str, ...] = ()) -> None:
    """Analytic against central differences (forward ones for parameters at their lower bound); ``inert``
    parameters change nothing at these values, and their analytic derivative must be zero too."""
    prediction, jacobian = model.prediction_and_jacobian(data, p)
    np.testing.assert_allclose(prediction, model.predict(data, p), rtol=1e-13)
    for q in model.parameters():
        step = 1e-3 * q.prior_scale
        if q.name in at_lower_bound:
            up = dict(p, **{q.name: p[q.name] + step})
            numeric = (4 * model.predict(data, up) - model.predict(data, dict(p, **{q.name: p[q.name] + 2 * step}))
                       - 3 * prediction) / (2 * step)
        else:
            numeric = finite_difference(model, data, p, q.name, step)
        analytic = jacobian.get(q.name, np.zeros(len(data)))
        size = np.max(np.abs(numeric))
        if q.name in inert:
            assert size == 0 and not np.any(analytic), q.name
            continue
        assert size > 0, f"{q.name}: no effect on the prediction at these values (test data too plain)"
        error = np.max(np.abs(analytic - numeric)) / size
        assert error < RELATIVE, f"{q.name}: analytic derivative off by {error:.2g} of its size"


def test_baseline_derivatives_match_finite_differences(station: StationConfig, data: Measurements) -> None:
    model = SensorModel(station.sensor)
    check(model, data, moved(model.parameters()))


@pytest.mark.parametrize("name", sorted(library()))
def test_each_library_effect_derivatives_match_finite_differences(station: StationConfig, data: Measurements,
                                                                  name: str) -> None:
    model = SensorModel(station.sensor, [name])
    assert model.has_derivatives
    check(model, data, moved(model.parameters()))


@pytest.mark.parametrize("changes", [{"plate_thickness": 8e-3}, {"plate_thickness": 1e-5}])
def test_skin_recession_derivatives_thick_and_thin_plate(station: StationConfig, data: Measurements,
                                                         changes: dict[str, float]) -> None:
    """A thick plate holds coth at 1 (past THICK_GAMMA_D at 15 kHz); a sheet is all tau_T change."""
    model = SensorModel(station.sensor, ["target_tau_temperature"])
    check(model, data, moved(model.parameters(), changes))


@pytest.mark.parametrize("changes", [{"plate_thickness": 45e-3}, {"plate_thickness": 0.2e-3}])
def test_plate_recession_derivatives_thick_and_thin_plate(station: StationConfig, data: Measurements,
                                                          changes: dict[str, float]) -> None:
    """A plate past THICK_GAMMA_D at both frequencies recedes by delta/2 whatever its thickness (d/dd is 0 there
    and must be 0 analytically too); a sheet recedes by about d/3 at each frequency."""
    model = SensorModel(station.sensor, ["plate_recession"])
    thick = changes["plate_thickness"] > 10e-3  # |gamma d| > THICK_GAMMA_D at 500 Hz
    check(model, data, moved(model.parameters(), changes), inert=("plate_thickness",) if thick else ())


def test_steel_target_tau_temperature_derivatives(data: Measurements) -> None:
    """A magnetic target: the tau_T change alone (no skin recession, no thickness)."""
    model = SensorModel(load_sensor("steel_target"), ["target_tau_temperature"])
    check(model, data, moved(model.parameters()))


@pytest.mark.parametrize("changes", [{"drying_order": 1.0}, {"drying_order": 0.0, "drying_onset": 60.0,
                                                            "drying_width": 1.0, "drying_rate": 3e-4}])
def test_moisture_derivatives_exponential_and_linear_drying(station: StationConfig, data: Measurements,
                                                            changes: dict[str, float]) -> None:
    """Drying in proportion to what is left (n = 1, the limit form) and at a constant pace until dry (n = 0)."""
    model = SensorModel(station.sensor, ["parasitic_capacitance"])
    check(model, data, moved(model.parameters(), changes))


def test_moisture_derivatives_without_bound_water(station: StationConfig, data: Measurements) -> None:
    """The simpler law (b = 0, where the fits start): the bound water's recurrences are skipped, but d/db is
    still the bound water's share (one-sided: b >= 0)."""
    model = SensorModel(station.sensor, ["parasitic_capacitance"])
    check(model, data, moved(model.parameters(), {"bound_share": 0.0}), at_lower_bound=("bound_share",),
          inert=("sorption_width",))


def test_a_swelling_former_and_its_moisture_carried_as_one_entry(station: StationConfig, data: Measurements) -> None:
    """The swelling acts on the coil's L and the distance through the moisture, carried as one latent entry and
    unfolded at the end (``Effect.latent_tangents``): exact for every parameter, for a subset of them as well, and
    the latent entry never reaches the caller."""
    model = SensorModel(station.sensor, ["parasitic_capacitance"])
    p = moved(model.parameters(), {"moist_swelling": 2e-3, "moist_dC": 15e-12, "bound_share": 0.5})
    check(model, data, p)
    _, full = model.prediction_and_jacobian(data, p)
    subset = ("drying_rate", "moist_swelling", "p1")
    _, some = model.prediction_and_jacobian(data, p, names=subset)
    assert set(some) == set(subset) and not any(name not in p for name in full)
    for name in subset:
        np.testing.assert_allclose(some[name], full[name], rtol=1e-12)


def test_effects_chain_through_each_other(station: StationConfig, data: Measurements) -> None:
    """Several effects at once: stage-1 tangents reach tau_T(x), the lag reaches every L term."""
    model = SensorModel(station.sensor, ["former_expansion", "target_bending", "tau_displacement", "thermal_lag",
                                         "target_tau_temperature", "parasitic_capacitance", "slide_backlash",
                                         "plate_recession"])
    check(model, data, moved(model.parameters()))


class _NoDerivative(Effect):
    name = "test_no_derivative"

    def parameters(self) -> list[Parameter]:
        return [Parameter("shift_ppm", 0.0, -100.0, 100.0, "ppm", "a change of L", 1.0)]

    def series_inductance(self, l_h, inputs, data, p):  # type: ignore[no-untyped-def]
        return l_h * (1 + 1e-6 * p["shift_ppm"])


class _MetalObjectWithDerivatives(Effect):
    """docs/user_effects.md's example effect with the derivative hook the page shows (the code as written there)."""

    name = "test_metal_object_with_derivatives"

    def parameters(self) -> list[Parameter]:
        return [Parameter("object_ppm", -400.0, -1e4, 1e4, "ppm", "change of L at the object", 50.0),
                Parameter("object_x", 0.047, 0.02, 0.10, "m", "slide position of the object", 2e-3),
                Parameter("object_width", 0.005, 0.001, 0.03, "m", "width of its influence", 1e-3)]

    def series_inductance(self, l_h, inputs, data, p):  # type: ignore[no-untyped-def]
        x = np.where(np.isfinite(data.x_m), data.x_m, np.inf)
        bump = np.exp(-0.5 * ((x - p["object_x"]) / p["object_width"]) ** 2)
        return l_h * (1 + 1e-6 * p["object_ppm"] * bump)

    def d_series_inductance(self, l_h, dl, inputs, d_inputs, data, p):  # type: ignore[no-untyped-def]
        near = np.isfinite(data.x_m)          # the coil in air: no bump, and no inf * 0 in the derivatives
        z = np.where(near, (np.where(near, data.x_m, 0.0) - p["object_x"]) / p["object_width"], 0.0)
        bump = np.where(near, np.exp(-0.5 * z**2), 0.0)
        factor = 1 + 1e-6 * p["object_ppm"] * bump
        own = {"object_ppm": l_h * 1e-6 * bump,                                   # d/d object_ppm
               "object_x": l_h * 1e-6 * p["object_ppm"] * bump * z / p["object_width"],
               "object_width": l_h * 1e-6 * p["object_ppm"] * bump * z**2 / p["object_width"]}
        return l_h * factor, chained(dl, factor, own)   # d(l factor) = factor dl + l d(factor)


def test_a_user_effect_on_the_series_inductance_with_its_derivative(station: StationConfig,
                                                                    data: Measurements) -> None:
    """The documented example: a hook after Eq. (2), so L_true's tangent is carried through it (the library has
    none there), chained with stage-1 effects."""
    model = SensorModel(station.sensor, ["target_bending", _MetalObjectWithDerivatives(station.sensor), "thermal_lag"])
    assert model.has_derivatives
    check(model, data, moved(model.parameters()))


def test_an_effect_without_derivatives_is_known_as_such(station: StationConfig) -> None:
    model = SensorModel(station.sensor, [_NoDerivative(station.sensor)])
    assert not model.has_derivatives
    assert SensorModel(station.sensor, ["thermal_lag"]).has_derivatives


@pytest.mark.parametrize("name", ["parasitic_capacitance", "tau_displacement"])
def test_what_an_effect_keeps_for_its_derivatives_is_never_another_parameters(station: StationConfig,
                                                                              data: Measurements, name: str) -> None:
    """The effects that keep an intermediate result for the derivatives asked for at the same parameters (the bound
    water's relaxation, the tau(x) spline): asked at other parameters in between, every answer is a fresh model's."""
    model = SensorModel(station.sensor, [name])
    here = moved(model.parameters())
    there = moved(model.parameters(), {q.name: q.value for q in model.effects[0].parameters()})
    assert any(here[k] != there[k] for k in here)
    for p in (here, there, here):
        value, tangent = model.prediction_and_jacobian(data, p)
        fresh = SensorModel(station.sensor, [name])
        expected_value, expected_tangent = fresh.prediction_and_jacobian(data, p)
        assert np.array_equal(value, expected_value) and np.array_equal(model.predict(data, p), fresh.predict(data, p))
        assert all(np.array_equal(tangent[k], expected_tangent[k]) for k in expected_tangent)


def test_tau_x_beyond_20_to_100_mm_chains_its_outer_knots(station: StationConfig) -> None:
    """Positions nearer than 20 mm and beyond 100 mm, where the spline runs straight to its outer knots: each knot,
    and the distance that former_expansion moves, differentiated as the predictions change."""
    assert station.simulated is not None
    data = campaign.paper_campaign(station.simulated.lab, seed=3, positions_mm=[11.0, 14.0, 17.0, 25.0, 40.0, 60.0,
                                                                                  90.0, 120.0, 150.0],
                                   interval_s=600.0)
    model = SensorModel(station.sensor, ["former_expansion", "tau_displacement"])
    check(model, data, moved(model.parameters(), {"tau_bend_10mm": 0.2, "tau_bend_150mm": -0.1}))
