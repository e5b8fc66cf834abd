"""A step's before/after figure shows the variable where the added effect's signature lives, and its legend
names the previous model (issue 24, point 4)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ecds_lab.analysis.associations import Association
from ecds_lab.report.sections import _step_plot
from ecds_lab.storage.data_file import open_data


def _step(effects: list[str], residuals: np.ndarray) -> SimpleNamespace:
    rms = float(np.sqrt(np.mean(residuals**2)))
    return SimpleNamespace(effects=effects, fit=SimpleNamespace(residuals_ppm=residuals), rmse_ppm=rms,
                           residual_mm=residuals * 1e-3, full_scale_mm=80.0)


def test_an_effect_that_lives_in_x_is_shown_against_x_and_the_legend_names_the_previous_model(
        campaign_files: list[Path]):
    data = next(open_data(p).data for p in campaign_files if open_data(p).run.kind == "target_heating")
    rng = np.random.default_rng(4)
    after = rng.normal(0.0, 20.0, len(data))
    screw = np.where(np.isfinite(data.x_m), 80.0 * np.sin(2 * np.pi * np.nan_to_num(data.x_m) / 0.005 + 0.7), 0.0)
    # the final residual lives in temperature and time: three telling variables, none of them x
    diagnosis = SimpleNamespace(data=data, noise_ppm=20.0, associations=[
        Association("t_target_c", 0.3, ""), Association("t_coil_c", 0.2, ""), Association("time_s", 0.1, "")])
    before_step = _step(["target_bending"], after + screw)
    after_step = _step(["target_bending", "slide_lead_screw"], after)
    plot = _step_plot(diagnosis, before_step, after_step)
    variables, previous = plot.args[4], plot.args[6]
    assert variables[0] == "x_mm" and len(variables) == 3
    assert previous == "baseline + target_bending"
    assert plot.render().data[:4] == b"\x89PNG"


def test_an_effect_that_lives_in_target_temperature_leads_with_it(campaign_files: list[Path]):
    data = next(open_data(p).data for p in campaign_files if open_data(p).run.kind == "target_heating")
    after = np.random.default_rng(5).normal(0.0, 20.0, len(data))
    heat = 3.0 * (data.t_target_c - np.min(data.t_target_c)) * np.isfinite(data.x_m)
    diagnosis = SimpleNamespace(data=data, noise_ppm=20.0, associations=[Association("x_mm", 0.3, "")])
    plot = _step_plot(diagnosis, _step([], after + heat), _step(["target_tau_temperature"], after))
    assert plot.args[4][0] in ("t_target_c", "time_s") and "x_mm" in plot.args[4]
    assert plot.args[6] == "baseline"
