"""The diagnosis on physics the library lacks (issue 23, Done-when 2): each imperfection of the wider world
(docs/simulated_lab.md, "Imperfections of the wider world"), switched on alone on the faithful lab at a size
within its typical range, in a campaign whose design can show it. The diagnosis must say "outside the library"
with the right association among its leading ones, and claim nothing false; bridge noise growing with the
heater current must raise no alarm at all."""

from __future__ import annotations

import json
from functools import cache

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import FAILING_RATIO, run_diagnosis
from ecds_lab.simulators import campaign
from ecds_lab.study.campaigns import measure
from ecds_lab.study.cases import Case, Design

#: Nine positions over 20-100 mm, two target and two coil set points: a few hundred readings, every phase.
POSITIONS_MM = tuple(float(x) for x in np.linspace(20.0, 100.0, 9))
#: The associations a verdict's "where it lives" names first (the leading ones).
LEADING = 2


#: Every 4 mm: a design that resolves a bump of 15 mm full width (the metal object's), which nine positions 10 mm
#: apart cannot tell from a smooth calibration and tau(x) (there the diagnosis rightly finds the model adequate).
FINE_POSITIONS_MM = tuple(float(x) for x in np.arange(20.0, 100.01, 4.0))


#: The coil heated to 60 C, then 100 C, in air (each held about six of the box's and former's time constants).
COIL_SETPOINTS_C = (60.0, 100.0)
#: The coil back at 60 C from above after 100 C, held as long: a hysteresis (a dead band) is memory independent of
#: rate, so at one steady temperature approached from both sides it leaves two levels, where a lag (which acts only
#: while the temperature changes) leaves none once the hold is several of its time constants long. Heated from below
#: only, each steady level is offset alike and a temperature coefficient takes it, and on the ramps a dead band looks
#: like a longer lag; this design is the one that can show it (docs/simulated_lab.md: the strain differs between
#: heating and cooling by alpha_exp * w at one temperature).
BOTH_SIDES_C = (60.0, 100.0, 60.0)


@cache
def _campaign(make_config, parts_json: str, positions_mm: tuple[float, ...],
              coil_setpoints_c: tuple[float, ...] = COIL_SETPOINTS_C):
    config = make_config(5, **json.loads(parts_json))
    return campaign.paper_campaign(config, seed=config.seed, positions_mm=positions_mm, target_setpoints_c=(75, 130),
                                   coil_setpoints_c=coil_setpoints_c)


def wider_world(make_config, name: str, size: dict, positions_mm: tuple[float, ...] = POSITIONS_MM,
                coil_setpoints_c: tuple[float, ...] = COIL_SETPOINTS_C, **parts: dict):
    """The campaign with the imperfection ``name`` on at ``size`` (and ``parts`` it acts on), made once."""
    parts_json = json.dumps({"imperfections": {name: {"enabled": True, **size}}, **parts}, sort_keys=True)
    return _campaign(make_config, parts_json, positions_mm, coil_setpoints_c)


def leading(result) -> list[str]:
    return [a.variable for a in result.associations[:LEADING]]


#: The field solution's change of tau_T with x is real structure of the faithful lab (test_error_model.py), and its
#: winding lags the coil's thermocouple (docs/simulated_lab.md, "Temperatures": winding_tau_s 300 s) whenever the
#: coil is heated, as in every campaign here: claiming tau_displacement or thermal_lag is true.
FAITHFUL = {"tau_displacement", "thermal_lag"}

#: name -> size (in the typical range), parts it acts on, variables it lives in, library effects truly present.
CASES = {
    "bridge_gain_drift": ({"ppm_per_hour": 150.0}, {}, {"time_s"}, FAITHFUL),
    "metal_object": ({"radius_mm": 4.0, "radial_mm": 80.0}, {"positions_mm": FINE_POSITIONS_MM}, {"x_mm"}, FAITHFUL),
    "target_tilt": ({"tilt_urad_per_k": 30.0}, {}, {"t_target_c"}, FAITHFUL),
    "expansion_hysteresis": ({"width_k": 8.0}, {"former": {"expansion": {"enabled": True}},
                                                "coil_setpoints_c": BOTH_SIDES_C},
                             {"t_coil_c", "coil_rate_k_per_min", "time_s"}, FAITHFUL | {"former_expansion"}),
    "reabsorption": ({"relative_humidity": 0.7, "groove_uptake_tau_s": 1800.0},
                     {"former": {"moisture": {"enabled": True}}},
                     {"t_coil_c", "coil_rate_k_per_min", "time_s"}, FAITHFUL | {"parasitic_capacitance"}),
}

#: What the diagnosis says instead, where it is wrong (issue 23, Done-when 2: not met for these yet).
WRONG = {
    "target_tilt": "names target_bending (fitted 4.50 +- 0.36 um/K: the tilt's 30 urad/K about a pivot 150 mm away "
                   "brings the plate's centre 4.5 um/K nearer) and calls the model adequate: the tilt's only "
                   "observable beyond bending's, the face-average term, is 1.4 ppm at 20 mm against 40 ppm of noise "
                   "(docs/simulated_lab.md); see test_a_tilt_is_read_as_the_bending_it_looks_like. Nor does a denser "
                   "design show it: every 2 mm over 20-40 mm, two readings each, four target set points 60-130 C, or "
                   "15 kHz alone with three readings each: target_bending claimed, no structure left (-10, -8 sd)",
}


def _case(name: str):
    if name in WRONG:
        return pytest.param(name, marks=pytest.mark.xfail(strict=True, reason=WRONG[name]))
    return name


@pytest.mark.parametrize("name", [_case(name) for name in CASES])
def test_an_imperfection_outside_the_library_is_said_to_be_and_located(field_config, name):
    size, parts, where, present = CASES[name]
    result = run_diagnosis(wider_world(field_config, name, size, **parts))
    assert result.verdict == "missing_effect", result.explanation
    assert "outside the library" in result.explanation, result.explanation
    assert set(leading(result)) & where, (leading(result), result.explanation)
    assert set(result.claimed) <= present, result.explanation  # nothing claimed that is not in the truth
    assert all(set(group) <= present for group in result.alternatives), result.explanation


@pytest.mark.parametrize("seed", [7, 2030])
def test_a_bump_in_every_sweep_is_not_taken_for_noise(seed):
    """A bracket's bump two or three positions wide in every sweep (16 positions, 5.3 mm apart), in a study-style
    campaign: one cold and one hot sweep of each frequency, no repeated readings, the coil heated in air between.
    A smooth of a sweep's residual cannot follow the bump, so about a smooth alone it counted as noise and hid
    itself (x 6.7 and 6.8 standard deviations beyond chance, the model called adequate). The final residual is
    judged with the noise beside the other sweep over the same positions (docs/diagnosis.md)."""
    design = Design(frequencies_hz=(500.0, 15000.0), directions=("forward",), positions=16, fine_steps=False,
                    target_setpoints_c=(), coil_setpoints_c=(40.0, 80.0, 120.0), repeats=1)
    bracket = {"enabled": True, "position_mm": 50.7, "radius_mm": 3.3, "radial_mm": 75.0 + 3.3 + 0.65}
    case = Case(0, seed, design, ("metal_object",), {"imperfections": {"metal_object": bracket}})
    result = run_diagnosis(measure(case))
    assert "outside the library" in result.explanation, result.explanation
    assert "x_mm" in leading(result), (leading(result), result.explanation)
    assert set(result.claimed) <= FAITHFUL, result.explanation


def test_bridge_noise_growing_with_the_heater_current_raises_no_alarm(field_config):
    result = run_diagnosis(wider_world(field_config, "bridge_heater_pickup",
                                       {"ppm_per_ampere": {"fast": 300.0, "medium": 90.0, "slow": 30.0}}))
    assert set(result.claimed) <= FAITHFUL and not result.alternatives, result.explanation
    assert result.final.rmse_ppm <= FAILING_RATIO * result.noise_ppm, result.explanation
    assert "outside the library" not in result.explanation


def test_a_tilt_is_read_as_the_bending_it_looks_like(field_config):
    """A tilt about a pivot off the coil's axis brings the plate's centre nearer by theta * pivot in proportion to
    its temperature rise: bending's observable. The diagnosis names bending (claimed or tied) at that rate."""
    result = run_diagnosis(wider_world(field_config, "target_tilt", CASES["target_tilt"][0]))
    named = set(result.claimed) | {n for group in result.alternatives for n in group}
    assert "target_bending" in named, result.explanation
    assert set(result.claimed) <= FAITHFUL | {"target_bending", "target_tau_temperature"}, result.explanation
    bending = next(s for s in result.steps[1:] if s.effects[-1] == "target_bending").fit.values["bending"]
    assert bending == pytest.approx(30e-6 * 0.150, rel=0.25)


@pytest.mark.parametrize("coil_setpoints_c", [COIL_SETPOINTS_C, BOTH_SIDES_C])
def test_a_cooling_hysteresis_is_not_claimed_as_drying(field_config, coil_setpoints_c):
    """The former's expansion lagging by a dead band on cooling leaves the cooling path off the heating one, as drying
    would; but the data leave the drying's course open (its rate where the fitted former dries unknown by orders of
    magnitude), so parasitic_capacitance is not claimed (before: claimed, fitted 53 fF, a false claim). Heated from
    below only (60, 100 C), where the design cannot show the hysteresis, and back at 60 C from above, where it can."""
    size, parts, _, present = CASES["expansion_hysteresis"]
    parts = {**parts, "coil_setpoints_c": coil_setpoints_c}
    result = run_diagnosis(wider_world(field_config, "expansion_hysteresis", size, **parts))
    assert "parasitic_capacitance" not in result.claimed, result.explanation
    assert set(result.claimed) <= present, result.explanation
    drying = [c for c in result.candidates if c.effect == "parasitic_capacitance"]
    assert all(not c.passes for c in drying)


def test_the_coil_back_from_above_without_a_hysteresis_raises_no_alarm(field_config):
    """The control of the design that shows a hysteresis: the same campaign (60, 100, 60 C) with the former's
    expansion following the winding without a dead band. The lag and the expansion explain it; nothing lies outside
    the library (before the residual was judged against each reading's own noise, both this and the hysteresis were
    'adequate': the sweeps' noise, larger than the holds', hid the holds' residual in one pooled RMS)."""
    data = _campaign(field_config, json.dumps({"former": {"expansion": {"enabled": True}}}), POSITIONS_MM, BOTH_SIDES_C)
    result = run_diagnosis(data)
    assert set(result.claimed) <= FAITHFUL | {"former_expansion"} and not result.alternatives, result.explanation
    assert "outside the library" not in result.explanation, result.explanation
