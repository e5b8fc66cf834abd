"""The wider world's imperfections (``simulated: lab: imperfections:``, docs/simulated_lab.md): each acts as its
physics says on the lab itself, through the campaigns built on it (``simulators/campaign.py``) and through the
instrument emulators that share it; each is off by default."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

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
    drift = lab._gain_drift
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
