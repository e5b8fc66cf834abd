"""A library effect beside a drift of the bridge's gain (docs/simulated_lab.md, `bridge_gain_drift`: |Z| scaled by
1 + g(t), g growing by ppm_per_hour plus a slow wander). The drift lies outside the library; what else the campaign
holds must still be found, and the drift located in time."""

from __future__ import annotations

from functools import cache

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.study.campaigns import measure
from ecds_lab.study.cases import Case, Design

#: The faithful lab's winding lags its thermocouple whenever the coil is heated, and its tau_T changes with x
#: (tests/analysis/test_diagnosis_wider_world.py): claiming either is true.
FAITHFUL = {"tau_displacement", "thermal_lag"}


@cache
def diagnosed():
    """Validation study seed 2033 case 41: one frequency (15 kHz), nine positions both ways, the target at 75 C, the
    coil at 60 and 120 C in air; the plate bends 0.61 um/K at its centre while the bridge's gain drifts -269 ppm/h
    (1950 ppm over the campaign's 7.3 h)."""
    design = Design(frequencies_hz=(15000.0,), directions=("forward", "backward"), positions=9, fine_steps=False,
                    target_setpoints_c=(75.0,), coil_setpoints_c=(60.0, 120.0), repeats=1)
    blocks = {"plate": {"bending": {"enabled": True, "centre_rise_um_per_k": 0.613}},
              "imperfections": {"bridge_gain_drift": {"enabled": True, "ppm_per_hour": -268.6, "wander_ppm": 6.36}}}
    return run_diagnosis(measure(Case(41, 1783000996, design, ("bending", "gain_drift"), blocks)))


def test_a_bending_beside_a_gain_drift_is_named_and_the_drift_located_in_time():
    """Beside a smooth in time the bending is absorbed (99 % of its signature is a smooth in time's: the target is hot
    in one window); beside a straight line in time, which takes 99.6 % of what the search left, it is not: at one
    frequency it ties with a conductivity change, an honest answer. Before, nothing was named but a part of the drift
    (former_expansion, not claimed)."""
    result = diagnosed()
    named = set(result.claimed) | {n for group in result.alternatives for n in group}
    assert "target_bending" in named, result.explanation
    assert set(result.claimed) <= FAITHFUL, result.explanation
    assert result.verdict == "missing_effect", result.explanation
    assert "outside the library" in result.explanation, result.explanation
    assert "time_s" in [a.variable for a in result.associations[:2]], result.explanation
    beside = [step for step in result.steps if step.beside_form == "straight line"]
    assert beside and beside[0].beside == ["time_s"], [(s.effects, s.beside_form) for s in result.steps]
