"""The slide's declared repeatability in the diagnosis: random scatter between moves, which no model
can predict, counts as noise when the station declares it, and is left as unexplained residual when
it does not; data without the declaration are judged exactly as before."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import FAILING_RATIO, diagnose, run_diagnosis
from ecds_lab.analysis.noise import estimate_noise
from ecds_lab.analysis.summary import fit_summary

#: The field solution's change of tau_T with x is real structure of the faithful lab (tests/analysis/
#: test_lead_screw.py): the model that knows it is the one whose residual the scatter is judged against.
KNOWN = ["tau_displacement"]
SIGMA_UM = 5.0


def declared(data, sigma_um: float):
    return dataclasses.replace(data, slide_repeatability_m=np.full(len(data), sigma_um * 1e-6))


@pytest.mark.parametrize("seed", [1, 2])
def test_declared_scatter_between_moves_is_noise_and_nothing_is_claimed(faithful_sweep_with, seed):
    data = faithful_sweep_with(seed, repeatability_um=SIGMA_UM)
    undeclared = run_diagnosis(data, KNOWN)
    assert undeclared.noise.positioning_ppm == 0.0
    assert undeclared.final.rmse_ppm > FAILING_RATIO * undeclared.noise.reading_ppm
    # Undeclared and unmeasured, the scatter is never called adequate: structure beyond chance (seed 2) is a
    # missing effect, scatter without it (seed 1) the noise estimate missing something, so inconclusive.
    assert undeclared.verdict in ("missing_effect", "inconclusive"), undeclared.explanation
    assert undeclared.claimed == []
    if undeclared.verdict == "inconclusive":
        assert "scatter more than the noise estimate" in undeclared.explanation
        assert "declare the slide's repeatability" in undeclared.explanation

    result = run_diagnosis(declared(data, SIGMA_UM), KNOWN)
    assert result.noise.reading_ppm == pytest.approx(undeclared.noise.reading_ppm, rel=1e-9)
    assert result.noise.positioning_ppm > result.noise.reading_ppm  # 5 um at ~10 ppm/um near 20 mm
    assert result.verdict == "adequate", result.explanation
    assert result.claimed == [] and result.alternatives == []
    assert result.final.rmse_ppm <= result.noise_ppm
    assert "slide positioning" in result.explanation and "declared repeatability" in result.explanation


def test_fit_and_diagnosis_report_the_same_noise_and_its_parts(faithful_sweep_with):
    data = declared(faithful_sweep_with(1, repeatability_um=SIGMA_UM), SIGMA_UM)
    fitted, diagnosed = fit_summary(data, KNOWN), diagnose(data, KNOWN)
    assert fitted["noise"] == diagnosed["noise"]
    assert fitted["noise_ppm"] == diagnosed["noise_ppm"]
    parts = diagnosed["noise"]
    assert set(parts) == {"reading_ppm", "positioning_ppm", "method"} and parts["positioning_ppm"] > 0
    assert diagnosed["noise_ppm"] == pytest.approx(np.hypot(parts["reading_ppm"], parts["positioning_ppm"]),
                                                   abs=2e-3)


def test_without_the_declaration_the_noise_is_todays_reading_noise(faithful_sweep_with):
    data = faithful_sweep_with(1, repeatability_um=SIGMA_UM)
    assert not data.slide_repeatability_m.any()
    result = run_diagnosis(data, KNOWN, max_steps=0)
    assert result.noise.positioning_ppm == 0.0
    assert result.noise_ppm == estimate_noise(result.data, result.baseline.residuals_ppm).ppm
    assert result.to_json()["noise"] == {"reading_ppm": round(result.noise_ppm, 3), "positioning_ppm": 0.0,
                                         "method": result.noise.method}


def test_revisits_no_positioning_scatter_explains_are_not_a_positioning_estimate(monkeypatch):
    """Revisit differences that no scatter up to centimetres explains (a sensitivity near zero there) give no
    positioning figure from the data: the declared one stands (the root search's bracket failed before)."""
    from types import SimpleNamespace

    from ecds_lab.analysis import positioning

    u = np.full(12, 50.0)
    monkeypatch.setattr(positioning, "_revisit_differences", lambda *args: (
        u, np.ones((12, 2)), np.full(12, 1e-12), np.arange(12)))
    data = SimpleNamespace(x_m=np.full(4, 0.03), slide_repeatability_m=np.full(4, 5e-6))
    estimate = positioning.estimate_positioning(data, np.zeros(4), np.ones(4), np.ones(4), np.zeros(4, int))
    assert estimate.dof == 0 and not np.isfinite(estimate.from_data_m) and estimate.sigma_m == 5e-6
