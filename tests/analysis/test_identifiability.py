"""What the data can test, from the Jacobian (issue 23, class 3): at one frequency a change of tau_T with
distance is a smooth change of the coupling a calibration absorbs; at two frequencies it is not. A lead
screw's short period is never absorbed. Ls alone at one frequency ties tau_T to the coupling's gain."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import run_diagnosis, search
from ecds_lab.analysis.diagnosis.identifiability import (
    absorbed,
    calibration_space,
    held_nuisances,
    releasable,
    start_values,
)
from ecds_lab.analysis.noise import NoiseEstimate
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.parameters import values_of
from ecds_lab.model.sensor_model import SensorModel

NOISE = NoiseEstimate(20.0, "test", 0)


def sweep(frequencies_hz: tuple[float, ...], step_mm: float = 2.0) -> Measurements:
    x = np.arange(20.0, 100.01, step_mm) * 1e-3
    xs, fs = np.meshgrid(x, frequencies_hz)
    n = xs.size
    data = Measurements(np.arange(n, dtype=float), xs.ravel(), fs.ravel(), np.full(n, 25.0), np.full(n, 25.0),
                        np.ones(n), np.ones(n))
    model = SensorModel()
    return Measurements(data.time_s, data.x_m, data.freq_hz, data.t_coil_c, data.t_target_c,
                        model.predict(data, values_of(model.parameters())), np.ones(n))


def verdict(effect: str, data: Measurements) -> str | None:
    base = SensorModel()
    values = values_of(base.parameters())
    free = [n for n in values if n not in base.unidentifiable(data)]
    model = SensorModel(effects=[effect])
    space = calibration_space(base, data, values, free, NOISE)
    return absorbed(model, data, start_values(model, values), space, NOISE)


def test_tau_of_x_is_absorbed_at_one_frequency_not_at_two():
    assert "absorbed by the calibration" in verdict("tau_displacement", sweep((15000.0,)))
    assert verdict("tau_displacement", sweep((500.0, 15000.0))) is None


@pytest.mark.parametrize("frequencies", [(15000.0,), (500.0, 15000.0)])
def test_a_short_lead_is_never_absorbed(frequencies):
    assert verdict("slide_lead_screw", sweep(frequencies, step_mm=1.0)) is None


def test_ls_alone_at_one_frequency_does_not_determine_tau_t():
    data = sweep((15000.0,))
    model = SensorModel()
    fixed = model.unidentifiable(data)
    values = values_of(model.parameters())
    free = [n for n in values if n not in fixed]
    assert "tau_t" in fixed
    assert "tau_t" not in releasable(model, data, values, free, fixed, NOISE)


def test_an_effect_claimed_after_another_is_not_listed_untestable(study_campaign, monkeypatch):
    """Validation study seed 2030 case 119 (two frequencies, a slide's backlash): tau(x) made absorbed
    beside the baseline alone, as an effect can be until another has changed how the readings respond to the coupling
    (seen on seed 2031 case 13 at 15 kHz: tau(x) beside a moisture change and an expansion, with the target heated
    by 110 K, before an expansion there became untestable beside the drying's held swelling). It is claimed after the
    backlash, and ``untestable`` keeps the last model's judgement: a claim and 'untestable' never stand side by
    side."""
    real = search._absorbed_at_every_shape

    def beside_the_baseline_alone(model, *args, **kwargs):
        if [e.name for e in model.effects] == ["tau_displacement"]:
            return "its signature is absorbed by the calibration in these data (beside the baseline alone)"
        return real(model, *args, **kwargs)

    monkeypatch.setattr(search, "_absorbed_at_every_shape", beside_the_baseline_alone)
    result = run_diagnosis(study_campaign(2030, 119))
    assert result.claimed.index("tau_displacement") > 0, result.explanation  # claimed, after another
    assert not set(result.claimed) & set(result.untestable), result.untestable


@pytest.mark.parametrize(("frequencies", "held"), [((15000.0,), ["moist_swelling"]), ((500.0, 15000.0), [])])
def test_the_drying_holds_its_swelling_at_one_frequency_only(frequencies, held):
    data = sweep(frequencies)
    heated = dataclasses.replace(data, t_coil_c=np.linspace(25.0, 120.0, len(data)))
    assert held_nuisances(SensorModel(effects=["parasitic_capacitance"]), heated) == held
    assert held_nuisances(SensorModel(effects=["former_expansion"]), heated) == []
