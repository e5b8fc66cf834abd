"""The wider world's imperfections (``simulated: lab: imperfections:``, docs/simulated_lab.md): each acts as its
physics says on the lab itself, through the campaigns built on it (``simulators/campaign.py``) and through the
instrument emulators that share it; each is off by default."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.stats import median_abs_deviation

from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import BOX_HEATER_OUTPUT, TARGET_HEATER_OUTPUT, SimulatedLab

#: ECM physics with a silent bridge: every reading is the impedance itself.
QUIET_ECM: dict[str, Any] = {"physics": "ecm", "noise": {"bridge_relative": {"fast": 0.0, "medium": 0.0, "slow": 0.0}}}
#: Field physics with a silent, glitch-free bridge (its fixed basic-accuracy error stays: constant per frequency).
QUIET_FIELD: dict[str, Any] = {"physics": "field",
                               "bridge": {"noise": {"enabled": False}, "glitches": {"enabled": False}}}
QUIET = {"ecm": QUIET_ECM, "field": QUIET_FIELD}
HOUR_S = 3600.0


def lab_with(physics: str = "ecm", seed: int | None = 1, **imperfections: dict[str, Any]) -> SimulatedLab:
    """A quiet lab of the given physics with the named imperfections (each a settings dict, switched on)."""
    blocks = {name: {"enabled": True, **settings} for name, settings in imperfections.items()}
    return SimulatedLab(LabConfig(**QUIET[physics], imperfections=blocks, seed=seed))


def inductance_h(lab: SimulatedLab, frequency_hz: float = 15000.0, **read: Any) -> float:
    return lab.measured_impedance(frequency_hz, **read).imag / (2 * math.pi * frequency_hz)


def test_every_imperfection_is_off_by_default():
    assert LabConfig().imperfections.enabled() == []


# -- 1. the bridge's gain drifts ---------------------------------------------------------------------------------
@pytest.mark.parametrize("physics", ["ecm", "field"])
def test_gain_drift_moves_a_fixed_state_reading_by_the_configured_ppm_per_hour(physics):
    lab = lab_with(physics, bridge_gain_drift={"ppm_per_hour": 120.0, "wander_ppm": 0.0})
    campaign.move_to(lab, 40.0)
    start = lab.clock.now()
    first = lab.measured_impedance(15000.0)
    lab.clock.advance(2 * HOUR_S)
    later = lab.measured_impedance(15000.0)
    expected = 120e-6 * (lab.clock.now() - start) / HOUR_S
    assert later / first - 1 == pytest.approx(expected, rel=1e-6)  # |Z| scaled, the phase kept
    assert lab.coil_impedance(15000.0) == pytest.approx(lab.coil_impedance(15000.0))  # the true impedance: no drift


def test_gain_drift_acts_in_air_and_at_every_frequency():
    lab = lab_with("field", bridge_gain_drift={"ppm_per_hour": -200.0, "wander_ppm": 0.0})
    lab.config.target_present = False
    before = {f: lab.measured_impedance(f) for f in (500.0, 15000.0, 100e3)}
    lab.clock.advance(HOUR_S)
    for frequency, z in before.items():
        assert abs(lab.measured_impedance(frequency)) / abs(z) - 1 == pytest.approx(-200e-6, rel=1e-3)


def test_gain_wander_has_its_rms_and_is_slow():
    lab = lab_with("ecm", bridge_gain_drift={"ppm_per_hour": 0.0, "wander_ppm": 30.0, "wander_time_s": 600.0})
    drift = lab.wider.gain_drift
    assert drift is not None
    g = np.array([drift.gain(t) - 1 for t in np.arange(0.0, 400 * 600.0, 60.0)])
    assert 20e-6 < g.std() < 40e-6
    # One minute apart, a tenth of the correlation time: correlated as e^{-0.1}, steps of sqrt(2 (1 - e^{-0.1})) rms.
    assert np.corrcoef(g[:-1], g[1:])[0, 1] == pytest.approx(math.exp(-0.1), abs=0.03)
    assert np.diff(g).std() == pytest.approx(math.sqrt(2 * (1 - math.exp(-0.1))) * g.std(), rel=0.15)


def test_gain_wander_is_a_fixed_function_of_time_whenever_the_lab_is_read():
    settings = {"wander_ppm": 40.0, "wander_time_s": 900.0}
    often, once = lab_with("ecm", bridge_gain_drift=settings), lab_with("ecm", bridge_gain_drift=settings)
    for _ in range(100):
        often.clock.advance(37.0)
        often.measured_impedance(500.0)
    once.clock.advance(3700.0)
    assert once.measured_impedance(500.0) == often.measured_impedance(500.0)


def test_gain_drift_acts_in_a_campaign_and_leaves_the_noise_draws_alone():
    drift = {"enabled": True, "ppm_per_hour": 300.0, "wander_ppm": 0.0}
    plain = campaign.paper_campaign(LabConfig(physics="field"), seed=3, positions_mm=(30.0, 60.0),
                                    target_setpoints_c=(60,), coil_setpoints_c=(60,))
    drifting = campaign.paper_campaign(LabConfig(physics="field", imperfections={"bridge_gain_drift": drift}),
                                       seed=3, positions_mm=(30.0, 60.0), target_setpoints_c=(60,),
                                       coil_setpoints_c=(60,))
    assert np.array_equal(plain.time_s, drifting.time_s)
    ratio = drifting.ls_h / plain.ls_h - 1
    np.testing.assert_allclose(ratio, 300e-6 * plain.time_s / HOUR_S, rtol=1e-6, atol=1e-12)
    assert plain.time_s.max() > HOUR_S


def test_gain_drift_reaches_the_bridge_emulator(open_sim_station):
    station = open_sim_station(**QUIET_ECM, imperfections={
        "bridge_gain_drift": {"enabled": True, "ppm_per_hour": 400.0, "wander_ppm": 0.0}})
    station.slide.move_to(0.040)
    station.bridge.set_frequency(15000)
    first = station.bridge.measure().main
    station.lab.clock.advance(2 * HOUR_S)
    assert station.bridge.measure().main / first - 1 == pytest.approx(800e-6, abs=20e-6)


def test_gain_drift_out_of_range_is_refused_naming_the_field():
    with pytest.raises(ValueError, match=r"bridge_gain_drift\.ppm_per_hour"):
        LabConfig(imperfections={"bridge_gain_drift": {"enabled": True, "ppm_per_hour": 5e4}})


# -- 5. bridge noise grows with the heater current ---------------------------------------------------------------
def relative_scatter(lab: SimulatedLab, n: int = 3000, frequency_hz: float = 15000.0) -> float:
    """rms of the reading's reactance about its mean, relative to |Z| (each reading 0.6 s after the last)."""
    values = []
    for _ in range(n):
        lab.clock.advance(0.6)
        values.append(lab.measured_impedance(frequency_hz))
    z = np.array(values)
    return float(z.imag.std() / np.abs(z).mean())


def test_bridge_noise_grows_with_the_heater_current_as_configured():
    """In air (the target heater then changes nothing the bridge sees): 20 ppm of the bridge's own noise and
    15 ppm/A of pickup add in quadrature; the pickup is proportional to the current."""
    config = {"physics": "ecm", "target_present": False, "noise": {"bridge_relative": {"slow": 20e-6}},
              "imperfections": {"bridge_heater_pickup": {"enabled": True, "ppm_per_ampere": {"slow": 15.0}}}}
    lab = SimulatedLab(LabConfig(**config))
    assert relative_scatter(lab) == pytest.approx(20e-6, rel=0.06)
    for volts in (8.0, 24.0):  # 1 A and 3 A through the 8 Ohm heater
        lab.set_supply(TARGET_HEATER_OUTPUT, voltage_v=volts, current_limit_a=4.0, on=True)
        amperes = volts / 8.0
        assert lab.heater_currents_a() == (pytest.approx(amperes), 0.0)
        assert relative_scatter(lab) == pytest.approx(math.hypot(20e-6, 15e-6 * amperes), rel=0.06)


def test_both_heaters_currents_add_in_quadrature():
    lab = lab_with("ecm", bridge_heater_pickup={"ppm_per_ampere": {"slow": 20.0}})
    lab.config.target_present = False
    lab.set_supply(TARGET_HEATER_OUTPUT, voltage_v=24.0, current_limit_a=4.0, on=True)  # 3 A
    lab.set_supply(BOX_HEATER_OUTPUT, voltage_v=32.0, current_limit_a=4.0, on=True)  # 4 A
    lab.clock.advance(20 * HOUR_S)  # the coil settled at its new temperature: only the noise varies
    assert relative_scatter(lab) == pytest.approx(20e-6 * 5.0, rel=0.06)


def test_heater_pickup_is_silent_while_no_heater_current_flows():
    lab = lab_with("field", bridge_heater_pickup={"ppm_per_ampere": {"slow": 30.0}})
    lab.set_supply(TARGET_HEATER_OUTPUT, voltage_v=12.0, current_limit_a=4.0, on=False)
    first = lab.measured_impedance(15000.0)
    assert lab.measured_impedance(15000.0) == first


def test_heater_pickup_shows_in_a_campaign_while_heating():
    """Field physics, coil in air: noise of repeated readings before and while the target heater runs."""
    config = LabConfig(physics="field", imperfections={"bridge_heater_pickup": {"enabled": True}})
    lab = SimulatedLab(config.model_copy(update={"seed": 5}))
    cold, hot = campaign.Recorder(lab), campaign.Recorder(lab)
    campaign.read_in_air(cold, [15000.0], repeats=1500)
    campaign.set_heater(lab, TARGET_HEATER_OUTPUT, 100.0)  # 78 W in 8 Ohm: 3.1 A
    campaign.read_in_air(hot, [15000.0], repeats=1500)
    amperes = lab.heater_currents_a()[0]
    # robust scatter: the field bridge's rare glitches stay on
    quiet, noisy = (float(median_abs_deviation(r.measurements().ls_h, scale="normal") / np.mean(r.measurements().ls_h))
                    for r in (cold, hot))
    assert amperes == pytest.approx(math.sqrt(78.0 / 8.0), rel=1e-3)
    assert quiet == pytest.approx(15e-6, rel=0.1)  # the bridge's own slow noise at 15 kHz
    assert noisy == pytest.approx(math.hypot(15e-6, 10e-6 * amperes), rel=0.1)


def test_heater_pickup_reaches_the_bridge_emulator(open_sim_station):
    station = open_sim_station(**QUIET_ECM, target_present=False, imperfections={
        "bridge_heater_pickup": {"enabled": True, "ppm_per_ampere": {"slow": 200.0}}})
    station.bridge.set_frequency(15000)
    off = np.array([station.bridge.measure().main for _ in range(150)])
    station.lab.set_supply(TARGET_HEATER_OUTPUT, voltage_v=16.0, current_limit_a=4.0, on=True)  # 2 A
    on = np.array([station.bridge.measure().main for _ in range(150)])
    assert off.std() / off.mean() < 10e-6  # the display's last digit
    assert on.std() / on.mean() == pytest.approx(400e-6, rel=0.2)


def test_heater_pickup_out_of_range_is_refused_naming_the_field():
    with pytest.raises(ValueError, match=r"bridge_heater_pickup\.ppm_per_ampere"):
        LabConfig(imperfections={"bridge_heater_pickup": {"ppm_per_ampere": {"slow": -5.0}}})


# -- 3. a metal object beside the slide --------------------------------------------------------------------------
def biot_savart_field_squared(winding, turns_grid: tuple[int, int], point: np.ndarray, segments: int = 720) -> float:
    """|H|^2 per A^2 at ``point`` from the winding as straight segments summed by Biot-Savart (an independent
    check of the elliptic-integral loops)."""
    radial = np.linspace(winding.inner_radius_m, winding.outer_radius_m, 2 * turns_grid[0] + 1)[1::2]
    axial = np.linspace(0.0, winding.height_m, 2 * turns_grid[1] + 1)[1::2]
    phi = np.linspace(0.0, 2 * np.pi, segments + 1)
    total = np.zeros(3)
    for r in radial:
        for z in axial:
            ends = np.stack([r * np.cos(phi), r * np.sin(phi), np.full_like(phi, z)], axis=1)
            mid, dl = 0.5 * (ends[1:] + ends[:-1]), np.diff(ends, axis=0)
            rel = point - mid
            total += (np.cross(dl, rel) / np.linalg.norm(rel, axis=1)[:, None] ** 3).sum(axis=0) / (4 * np.pi)
    return float(total @ total) * (winding.turns / (radial.size * axial.size)) ** 2


def object_change_ppm(physics: str, x_mm: float, frequency_hz: float = 500.0, **settings: Any) -> float:
    """The change of the reading's L that the object (default settings updated) makes at x, in ppm of the
    coil's L in air (53.6 mH, the paper's coil)."""
    with_object = lab_with(physics, metal_object=settings)
    without = lab_with(physics)
    values = []
    for lab in (with_object, without):
        campaign.move_to(lab, x_mm)
        values.append(inductance_h(lab, frequency_hz))
    return (values[0] - values[1]) / 53.6e-3 * 1e6


def test_polarizability_reaches_its_limits_and_the_non_magnetic_closed_form():
    from ecds_lab.simulators.physics.metal_object import polarizability

    assert polarizability(2 * np.pi * 500, 3e-3, 0.0, 100.0) == pytest.approx(99 / 102)  # magnetostatic sphere
    assert polarizability(2 * np.pi * 1e9, 3e-3, 6e7, 1.0) == pytest.approx(-0.5, abs=2e-3)  # perfect conductor
    for frequency in (50.0, 500.0, 15000.0):
        z = 3e-3 * np.sqrt(1j * 2 * np.pi * frequency * 4e-7 * np.pi * 3.5e7)
        wait = -0.5 * (1 + 3 / z**2 - 3 / (np.tanh(z) * z))  # Wait (1951), mu_r = 1
        assert polarizability(2 * np.pi * frequency, 3e-3, 3.5e7, 1.0) == pytest.approx(wait, rel=1e-9)


def test_a_non_conducting_magnetic_object_changes_l_by_its_dipole_in_the_coils_field():
    """sigma = 0: dL = mu0 4 pi a^3 (mu_r - 1)/(mu_r + 2) |H|^2, H from Biot-Savart over the winding."""
    from ecds_lab.simulators.physics.field_solution import Winding
    from ecds_lab.simulators.physics.metal_object import MetalObject, MetalObjectNearby

    winding = Winding(0.055, 0.075, 0.003, 500)
    settings = MetalObject(enabled=True, conductivity_s_per_m=0.0, mu_r=200.0, radius_mm=2.0, radial_mm=80.0)
    nearby = MetalObjectNearby(settings, winding)
    for x_mm in (45.0, 50.0, 60.0):
        point = np.array([0.080, 0.0, (45.0 - x_mm) * 1e-3 + 0.0015])
        expected = 4e-7 * np.pi * 4 * np.pi * 2e-3**3 * 199 / 202 * biot_savart_field_squared(winding, (40, 6), point)
        assert nearby.inductance_h(2 * np.pi * 500, x_mm * 1e-3) == pytest.approx(expected, rel=2e-3)


@pytest.mark.parametrize("physics", ["ecm", "field"])
def test_metal_object_changes_l_only_near_its_place_and_by_a_few_hundred_ppm(physics):
    """Defaults: a steel object of 3 mm radius, 3.5 mm beyond the winding's rim, passed at 45 mm."""
    peak = object_change_ppm(physics, 45.0)
    assert 100 < peak < 400  # steel at 500 Hz: magnetized, L rises
    profile = {x: object_change_ppm(physics, x) for x in (37.0, 41.0, 49.0, 53.0, 70.0, 100.0, 130.0)}
    assert profile[41.0] == pytest.approx(profile[49.0], rel=0.02)  # symmetric about its place
    assert peak / 2 < profile[41.0] < peak and profile[37.0] < peak / 2  # about 16 mm wide at half height
    # tails falling about as the square of the distance: 25, 55, 85 mm away
    assert 0 < profile[70.0] < 0.15 * peak and 0 < profile[100.0] < 0.04 * peak and 0 < profile[130.0] < 0.01 * peak
    assert object_change_ppm(physics, 80.0, position_mm=80.0) == pytest.approx(peak, rel=0.01)  # placed elsewhere


def test_metal_object_frequency_dependence_follows_its_material():
    steel_low, steel_high = object_change_ppm("ecm", 45.0, 500.0), object_change_ppm("ecm", 45.0, 15000.0)
    assert steel_low > steel_high > 0  # eddy currents screen part of the magnetization at 15 kHz
    aluminium = {"conductivity_s_per_m": 3.5e7, "mu_r": 1.0}
    al_low = object_change_ppm("ecm", 45.0, 500.0, **aluminium)
    al_high = object_change_ppm("ecm", 45.0, 15000.0, **aluminium)
    assert al_high < al_low < 0  # a non-magnetic conductor only lowers L, more as its skin depth falls
    lab = lab_with("ecm", metal_object={})
    plain = lab_with("ecm")
    for each in (lab, plain):
        campaign.move_to(each, 45.0)
    assert lab.measured_impedance(15000.0).real > plain.measured_impedance(15000.0).real  # and it dissipates


def test_metal_object_acts_with_the_target_removed_where_the_carriage_is():
    lab, plain = lab_with("field", metal_object={}), lab_with("field")
    for each in (lab, plain):
        campaign.move_to(each, 45.0)
        each.config.target_present = False
    near = inductance_h(lab, 500.0) / inductance_h(plain, 500.0) - 1
    for each in (lab, plain):
        campaign.move_to(each, 120.0)
    far = inductance_h(lab, 500.0) / inductance_h(plain, 500.0) - 1
    assert near > 100e-6 and 0 < far < 0.02 * near


def test_metal_object_shows_in_a_campaign_sweep():
    positions = (30.0, 40.0, 45.0, 50.0, 60.0, 90.0)
    config = LabConfig(physics="field", imperfections={"metal_object": {"enabled": True}})
    with_object = campaign.paper_campaign(config, seed=2, positions_mm=positions, target_setpoints_c=(),
                                          coil_setpoints_c=())
    plain = campaign.paper_campaign(LabConfig(physics="field"), seed=2, positions_mm=positions,
                                    target_setpoints_c=(), coil_setpoints_c=())
    at = (with_object.x_m == 0.045) & (with_object.freq_hz == 500.0)
    far = (with_object.x_m == 0.09) & (with_object.freq_hz == 500.0)
    change = with_object.ls_h / plain.ls_h - 1
    assert np.all(change[at] > 100e-6) and np.all(np.abs(change[far]) < 0.05 * change[at].min())


def test_metal_object_reaches_the_bridge_emulator(open_sim_station):
    def reading_h(station) -> float:
        station.slide.move_to(0.045)
        station.bridge.set_frequency(500)
        return station.bridge.measure().main

    near = reading_h(open_sim_station(**QUIET_ECM, imperfections={"metal_object": {"enabled": True}}))
    assert near / reading_h(open_sim_station(**QUIET_ECM)) - 1 == pytest.approx(
        object_change_ppm("ecm", 45.0) * 1e-6, abs=15e-6)


def test_a_metal_object_touching_the_winding_is_refused_naming_the_field():
    with pytest.raises(ValueError, match=r"imperfections\.metal_object\.radial_mm"):
        LabConfig(imperfections={"metal_object": {"enabled": True, "radial_mm": 76.0}})


# -- 4. a target tilt that changes with temperature ---------------------------------------------------------------
def true_l_h(physics: str, x_mm: float, t_target_c: float, frequency_hz: float = 15000.0, **tilt: Any) -> float:
    """True L with the plate at ``t_target_c`` (its surface and bulk), the tilt on when settings are given; a
    field lab without carriage errors, so distances are exact."""
    config: dict[str, Any] = dict(QUIET[physics])
    if physics == "field":
        config["slide"] = {part: {"enabled": False} for part in ("backlash", "lead_screw", "repeatability")}
    if tilt:
        config["imperfections"] = {"target_tilt": {"enabled": True, **tilt}}
    lab = SimulatedLab(LabConfig(**config))
    campaign.move_to(lab, x_mm)
    lab.update()
    lab.t_target_c = lab.t_plate_surface_c = t_target_c
    return lab.coil_impedance(frequency_hz).imag / (2 * math.pi * frequency_hz)


def test_tilt_follows_the_plate_temperature_and_vanishes_at_ambient():
    from ecds_lab.simulators.physics.target_tilt import TargetTilt, Tilt

    tilt = Tilt(TargetTilt(enabled=True, tilt_urad_per_k=10.0), 0.065, 22.0)
    assert tilt.angle_rad(132.0) == pytest.approx(1.1e-3)
    assert tilt.gaps_m(0.020, 22.0) is None
    gaps = tilt.gaps_m(0.020, 132.0)
    assert gaps is not None and np.mean(gaps) == pytest.approx(0.020 - 1.1e-3 * 0.150)  # the centre 165 um nearer
    assert max(gaps) - min(gaps) == pytest.approx(2 * 1.1e-3 * 0.065 * math.cos(math.pi / 8))  # rim +-72 um
    assert true_l_h("field", 30.0, 22.0, tilt_urad_per_k=50.0) == true_l_h("field", 30.0, 22.0)


@pytest.mark.parametrize("physics", ["ecm", "field"])
def test_tilt_moves_the_centre_by_angle_times_pivot(physics):
    """10 urad/K at a 110 K rise, pivot 150 mm: as the plate 165 um nearer, to within the face average."""
    for x_mm in (20.0, 50.0):
        flat_hot = true_l_h(physics, x_mm, 132.0)
        tilted = true_l_h(physics, x_mm, 132.0, tilt_urad_per_k=10.0)
        shifted = true_l_h(physics, x_mm - 0.165, 132.0)
        assert tilted / flat_hot - 1 < -50e-6  # clearly nearer
        assert tilted / shifted - 1 == pytest.approx(0.0, abs=3e-6)  # and the face average adds ppm at most


@pytest.mark.parametrize("physics", ["ecm", "field"])
def test_tilt_about_the_centre_changes_l_beyond_any_uniform_shift(physics):
    """Pivot 0: the mean gap is kept, yet the average coupling over a tilted face is larger (it is convex in
    the gap), so L falls, as the square of the tilt, and by an x dependence no uniform shift has."""
    def change(x_mm: float, t_c: float) -> float:
        return true_l_h(physics, x_mm, t_c, tilt_urad_per_k=50.0, pivot_mm=0.0) - true_l_h(physics, x_mm, t_c)

    assert change(20.0, 122.0) < 0
    assert change(20.0, 122.0) / change(20.0, 72.0) == pytest.approx(4.0, rel=0.02)  # quadratic in the tilt
    # the shift that would explain it, change / (dL/dx), differs by x: no uniform shift reproduces the tilt
    slope = {x: (true_l_h(physics, x + 0.01, 122.0) - true_l_h(physics, x - 0.01, 122.0)) / 0.02e-3
             for x in (20.0, 60.0)}
    equivalent = {x: change(x, 122.0) / slope[x] for x in (20.0, 60.0)}
    assert equivalent[20.0] / equivalent[60.0] > 1.5 or equivalent[60.0] / equivalent[20.0] > 1.5


def test_tilt_acts_in_a_target_heating_campaign():
    options: dict[str, Any] = {"positions_mm": (20.0, 40.0), "frequencies_hz": (15000.0,),
                               "directions": ("forward",)}
    config = LabConfig(physics="field", imperfections={"target_tilt": {"enabled": True}})
    tilted = campaign.target_heating(SimulatedLab(config), (22.0, 130.0), **options)
    flat = campaign.target_heating(SimulatedLab(LabConfig(physics="field")), (22.0, 130.0), **options)
    change = tilted.ls_h / flat.ls_h - 1
    cold, hot = flat.t_target_c < 30.0, flat.t_target_c > 120.0
    assert np.all(np.abs(change[cold]) < 1e-9)
    assert np.all(change[hot & (flat.x_m == 0.02)] < -1000e-6)  # 160 um nearer at 20 mm


def test_tilt_reaches_the_bridge_emulator(open_sim_station):
    def heated_reading_h(station) -> float:
        station.slide.move_to(0.020)
        station.bridge.set_frequency(15000)
        station.lab.set_supply(TARGET_HEATER_OUTPUT, voltage_v=28.0, current_limit_a=4.0, on=True)  # 98 W
        station.lab.clock.advance(3 * HOUR_S)
        return station.bridge.measure().main

    tilted = open_sim_station(**QUIET_ECM, imperfections={"target_tilt": {"enabled": True}})
    flat = open_sim_station(**QUIET_ECM)
    measured = heated_reading_h(tilted) / heated_reading_h(flat) - 1
    true = tilted.lab.coil_impedance(15000.0).imag / flat.lab.coil_impedance(15000.0).imag - 1
    assert true < -1000e-6 and measured == pytest.approx(true, abs=15e-6)


# -- 2. a hysteresis of the former's expansion -------------------------------------------------------------------
def test_the_play_follows_only_beyond_half_the_width():
    from ecds_lab.simulators.physics.expansion_hysteresis import ExpansionHysteresis, ExpansionPlay

    play = ExpansionPlay(ExpansionHysteresis(enabled=True, width_k=4.0), 22.0)
    path = [23.0, 24.0, 30.0, 29.0, 27.0, 26.0, 20.0, 21.0, 22.0]
    followed = []
    for t in path:
        play.follow(t)
        followed.append(play.temperature_c)
    assert followed == [22.0, 22.0, 28.0, 28.0, 28.0, 28.0, 22.0, 22.0, 22.0]


def twin_in_air(physics: str, width_k: float, **extra: Any) -> tuple[SimulatedLab, SimulatedLab]:
    """Two labs, coil in air, moisture off, with and without the hysteresis; the same schedule gives both
    the same temperatures."""
    config: dict[str, Any] = {**QUIET[physics], "target_present": False, **extra}
    if physics == "field":
        config["former"] = {"expansion": {"per_k": 25e-6}, "moisture": {"enabled": False}}
    plain = SimulatedLab(LabConfig(**config))
    hysteretic = SimulatedLab(LabConfig(**config, imperfections={
        "expansion_hysteresis": {"enabled": True, "width_k": width_k}}))
    return hysteretic, plain


@pytest.mark.parametrize("physics", ["ecm", "field"])
def test_hysteresis_separates_the_heating_and_cooling_paths_by_the_width(physics):
    """Heating runs w/2 below the winding's temperature, cooling w/2 above: the relative change of L is
    -alpha w/2 heating, +alpha w/2 cooling, and +alpha w/2 stays after the cycle (alpha: L's expansion tempco,
    field: the former's 25e-6/K in air; ECM: the configured alpha)."""
    hysteretic, plain = twin_in_air(physics, 8.0)
    alpha = 25e-6 if physics == "field" else plain.config.alpha

    def relative_change() -> float:
        return inductance_h(hysteretic, 500.0) / inductance_h(plain, 500.0) - 1

    assert relative_change() == pytest.approx(0.0, abs=1e-12)
    heating, cooling = [], []
    for lab in (hysteretic, plain):
        lab.set_supply(BOX_HEATER_OUTPUT, voltage_v=24.0, current_limit_a=4.0, on=True)  # 72 W: +86 K
    for _ in range(12):
        for lab in (hysteretic, plain):
            lab.clock.advance(300.0)
        heating.append((hysteretic.t_winding_c, relative_change()))
    for lab in (hysteretic, plain):
        lab.set_supply(BOX_HEATER_OUTPUT, on=False)
    for _ in range(48):
        for lab in (hysteretic, plain):
            lab.clock.advance(300.0)
        cooling.append((hysteretic.t_winding_c, relative_change()))
    assert heating[-1][0] > 90.0 and cooling[-1][0] < 23.0
    for _, change in heating[1:]:
        assert change == pytest.approx(-alpha * 4.0, rel=0.02)
    for _, change in cooling[2:]:
        assert change == pytest.approx(alpha * 4.0, rel=0.02)
    assert cooling[-1][1] - heating[-1][1] == pytest.approx(alpha * 8.0, rel=0.02)  # the paths, w apart


def test_hysteresis_acts_in_a_coil_heating_campaign():
    config: dict[str, Any] = {"physics": "field", "former": {"expansion": {"per_k": 25e-6}}}
    plain = campaign.coil_heating(SimulatedLab(LabConfig(**config)), (60.0,), (500.0,))
    hysteretic = campaign.coil_heating(SimulatedLab(LabConfig(**config, imperfections={
        "expansion_hysteresis": {"enabled": True, "width_k": 6.0}})), (60.0,), (500.0,))
    change = hysteretic.ls_h / plain.ls_h - 1
    hot_index = int(np.argmax(plain.t_coil_c))
    assert np.abs(change[:3]).max() < 1e-12  # before heating: the band is centred
    assert change[hot_index] == pytest.approx(-25e-6 * 3.0, rel=0.05)  # heating: 3 K behind
    assert change[-1] == pytest.approx(25e-6 * 3.0, rel=0.05)  # cooled: 3 K ahead, and kept


def test_hysteresis_reaches_the_bridge_emulator(open_sim_station):
    def heated_reading_h(station) -> float:
        station.bridge.set_frequency(500)
        station.lab.set_supply(BOX_HEATER_OUTPUT, voltage_v=20.0, current_limit_a=4.0, on=True)
        station.lab.clock.advance(2 * HOUR_S)
        return station.bridge.measure().main

    hysteretic = open_sim_station(**QUIET_ECM, target_present=False,
                                  imperfections={"expansion_hysteresis": {"enabled": True, "width_k": 10.0}})
    plain = open_sim_station(**QUIET_ECM, target_present=False)
    change = heated_reading_h(hysteretic) / heated_reading_h(plain) - 1
    assert change == pytest.approx(-plain.lab.config.alpha * 5.0, abs=15e-6)


# -- 6. re-absorption of humidity while cooling ------------------------------------------------------------------
def test_uptake_slows_as_the_surface_air_warms_and_dries():
    from ecds_lab.simulators.physics.humidity_uptake import HumidityUptake, Reabsorption

    uptake = HumidityUptake(Reabsorption(enabled=True, relative_humidity=0.5), 22.0)
    assert uptake.taus_s(22.0) == (3600.0, 4 * 3600.0)
    magnus = lambda t: 6.112 * math.exp(17.62 * t / (243.12 + t))  # noqa: E731  (WMO-No. 8, hPa)
    assert uptake.surface_humidity(40.0) == pytest.approx(0.5 * magnus(22.0) / magnus(40.0))
    assert uptake.taus_s(40.0)[0] == pytest.approx(3600.0 * magnus(40.0) / magnus(22.0))
    humid = HumidityUptake(Reabsorption(enabled=True, relative_humidity=0.8), 22.0)
    assert humid.taus_s(22.0)[0] == pytest.approx(3600.0 * 0.5 / 0.8)


def dried_then_cooled(lab: SimulatedLab) -> None:
    """Box heater to about 110 C for 3 h (the groove clay dries out), then off for 2 h."""
    lab.set_supply(BOX_HEATER_OUTPUT, voltage_v=27.0, current_limit_a=4.0, on=True)
    lab.clock.advance(3 * HOUR_S)
    lab.set_supply(BOX_HEATER_OUTPUT, on=False)
    lab.clock.advance(2 * HOUR_S)
    lab.update()


@pytest.mark.parametrize("humidity, tau_s", [(0.5, 3600.0), (0.25, 7200.0)])
def test_a_cooled_former_takes_water_up_again_within_its_time_constant(humidity, tau_s):
    settings = {"relative_humidity": humidity, "groove_uptake_tau_s": 3600.0}
    wet, slow = lab_with("field", reabsorption=settings), lab_with("field")
    for lab in (wet, slow):
        lab.config.target_present = False
        dried_then_cooled(lab)
    assert slow.former.groove < 0.05 and wet.t_former_c < 23.0  # dried, and cool again
    start = wet.former.groove
    wet.clock.advance(tau_s)
    wet.update()
    # at room temperature: 1 - m falls by e within tau (the equilibrium is 1 there)
    assert (1 - wet.former.groove) / (1 - start) == pytest.approx(math.exp(-1), rel=0.03)
    slow.clock.advance(tau_s)
    slow.update()
    assert slow.former.groove < 0.05  # the former's own re-absorption takes days
    capacitance = wet.former.parallel_elements(15000.0)[0]
    assert capacitance == pytest.approx(47.5e-12 + 15e-12 * wet.former.groove)  # C_p back toward its moist 62.5 pF
    assert capacitance > slow.former.parallel_elements(15000.0)[0] + 5e-12


def test_reabsorption_acts_on_the_ecm_moisture():
    effects = {"parasitic_capacitance": {"enabled": True}}
    fast = SimulatedLab(LabConfig(**QUIET_ECM, effects=effects, imperfections={"reabsorption": {"enabled": True}}))
    slow = SimulatedLab(LabConfig(**QUIET_ECM, effects=effects))
    for lab in (fast, slow):
        dried_then_cooled(lab)
    assert slow.moisture < 0.2 and fast.moisture > slow.moisture + 0.3
    assert fast.coil_impedance(15000.0).imag > slow.coil_impedance(15000.0).imag  # more C: apparent L up


def test_reabsorption_shows_after_a_coil_heating_campaign():
    """Readings in air at 15 kHz after the campaign's cool-down: the re-absorbing former's capacitance
    (apparent L = L / (1 - w^2 L C)) comes back, the other's does not."""
    def campaign_then_rest(config: LabConfig) -> np.ndarray:
        lab = SimulatedLab(config)
        rec = campaign.Recorder(lab)
        campaign.read_in_air(rec, [15000.0], 3)
        campaign.heat_and_record(rec, BOX_HEATER_OUTPUT, 120.0, [15000.0], in_air=True)
        campaign.heat_and_record(rec, BOX_HEATER_OUTPUT, None, [15000.0], in_air=True)
        for _ in range(6):
            lab.clock.sleep(1800.0)
            campaign.read_in_air(rec, [15000.0])
        return rec.measurements().ls_h

    plain = campaign_then_rest(LabConfig(physics="field", seed=4))
    wet = campaign_then_rest(LabConfig(physics="field", seed=4, imperfections={"reabsorption": {"enabled": True}}))
    moist_minus_dry = plain[:3].mean() - plain[-1]  # what drying took
    assert moist_minus_dry > 300e-6 * plain[0]
    recovered = (wet[-1] - plain[-1]) / moist_minus_dry
    assert 0.5 < recovered < 1.0  # hours after cooling: most of the groove's water back


def test_reabsorption_reaches_the_bridge_emulator(open_sim_station):
    def cooled_reading_h(station) -> float:
        station.bridge.set_frequency(15000)
        dried_then_cooled(station.lab)
        station.lab.clock.advance(HOUR_S)
        return station.bridge.measure().main

    wet = open_sim_station(**QUIET_FIELD, target_present=False, imperfections={"reabsorption": {"enabled": True}})
    plain = open_sim_station(**QUIET_FIELD, target_present=False)
    true = wet.lab.coil_impedance(15000.0).imag / plain.lab.coil_impedance(15000.0).imag - 1
    # the moist former's 15 pF raise the apparent L by 0.7 % at 15 kHz; most of it is back after 3 h cool
    assert cooled_reading_h(wet) / cooled_reading_h(plain) - 1 > 0.004
    assert true == pytest.approx(0.0, abs=1e-12)  # read before: both still moist


# -- all of them at once -----------------------------------------------------------------------------------------
ALL_ON: dict[str, Any] = {name: {"enabled": True} for name in LabConfig().imperfections.model_dump()}


@pytest.mark.parametrize("physics", ["ecm", "field"])
def test_all_imperfections_together_make_a_reproducible_campaign(physics):
    def run(imperfections: dict[str, Any]) -> Any:
        return campaign.paper_campaign(LabConfig(physics=physics, imperfections=imperfections), seed=7,
                                       positions_mm=(30.0, 45.0, 60.0), target_setpoints_c=(100,),
                                       coil_setpoints_c=(80,))

    first, again, plain = run(ALL_ON), run(ALL_ON), run({})
    assert sorted(LabConfig(imperfections=ALL_ON).imperfections.enabled()) == sorted(ALL_ON)
    assert np.array_equal(first.ls_h, again.ls_h) and np.array_equal(first.rs_ohm, again.rs_ohm)
    assert np.array_equal(first.time_s, plain.time_s)
    assert np.abs(first.ls_h / plain.ls_h - 1).max() > 100e-6
