"""The library holds for other plausible forms of the same physics, not just the simulator's.

Data are made by the sensor model with effect classes written differently from the library's
(resistivity-linear tau_T, tau_T rising like 1/x, bending weighted toward the coil, moisture that
dries at a constant pace above a threshold: "time spent hot"), plus bridge-like noise; the
diagnosis must still name the physics and bring the residual to the noise.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import pytest

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.analysis.fitting import fit
from ecds_lab.model.effects import Effect, Inputs
from ecds_lab.model.sensor_model import SensorModel

NOISE_PPM = 20.0


class ResistivityTau(Effect):
    name = "generator: tau follows resistivity"

    def target_tau(self, tau_s: np.ndarray, inputs: Inputs, data, p: Mapping[str, float]) -> np.ndarray:
        return tau_s / (1 + 0.0039 * (inputs.t_target_c - 20.0))


class InverseDistanceTau(Effect):
    name = "generator: tau rises like 1/x"

    def target_tau(self, tau_s: np.ndarray, inputs: Inputs, data, p: Mapping[str, float]) -> np.ndarray:
        x = np.where(np.isfinite(inputs.x_m), inputs.x_m, 0.06)
        return tau_s * (1 + 0.004 / x - 0.004 / 0.06)


class EdgeBending(Effect):
    name = "generator: bending felt more near the plate"

    def effective_distance(self, x_m: np.ndarray, data, p: Mapping[str, float]) -> np.ndarray:
        return x_m - 2e-6 * (data.t_target_c - 20.0) * (1 + (0.05 - x_m) / 0.05)


class TimeHotMoisture(Effect):
    name = "generator: capacitance falls with time spent above 60 C"

    def coil_capacitance(self, c_f: np.ndarray, inputs: Inputs, data, p: Mapping[str, float]) -> np.ndarray:
        order = np.argsort(data.time_s, kind="stable")
        hot = np.zeros(len(data))
        dt = np.diff(data.time_s[order], prepend=data.time_s[order][0])
        hot[order] = np.cumsum(dt * (data.t_coil_c[order] > 60.0))
        return c_f + 15e-12 * np.clip(1 - hot / 3600.0, 0, None)


@pytest.mark.parametrize("generator, effect", [
    (ResistivityTau, "target_tau_temperature"),
    (InverseDistanceTau, "tau_displacement"),
    (EdgeBending, "target_bending"),
    (TimeHotMoisture, "parasitic_capacitance"),
])
def test_library_names_the_physics_written_another_way(campaign_with, generator, effect):
    layout = campaign_with()
    truth = fit(layout, [])  # the baseline's parameters for this sensor
    model = SensorModel(effects=[generator(truth.model.sensor)])
    clean = model.predict(layout, truth.values)
    noise = np.random.default_rng(0).normal(0, NOISE_PPM * 1e-6, len(layout))
    data = dataclasses.replace(layout, ls_h=clean * (1 + noise))
    result = run_diagnosis(data, follow_up=False)
    assert result.best.effect == effect, [(c.effect, round(c.delta_bic)) for c in result.candidates]
    assert result.best.rmse_ppm <= 1.5 * result.noise_ppm
