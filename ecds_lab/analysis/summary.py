"""The `ecds-lab fit --json` summary: model fit, calibration and position errors as one JSON-able dict.

The fit uses all data (baseline plus named effects). Where the data hold a room-temperature
sweep at a frequency, that frequency is calibrated paper-style (all positions and the n = 4
sensitive ones; parameters other than L0 and p1..p4 held at the full fit's values) and the
position errors of room-temperature, coil-heated (with and without Eq. 4) and target-heated
readings are summarised in mm, % FS and ppm FS/K.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ecds_lab.analysis.calibration import (
    Calibration,
    PositionErrors,
    calibrate,
    position_errors,
    room_temperature_rows,
    temperature_stability_ppm_fs_per_k,
)
from ecds_lab.analysis.dataset import Measurements
from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.model.sensor import SensorConfig
from ecds_lab.model.sensor_model import SensorModel

#: Temperature rise (K) above room temperature that makes a reading "heated".
HEATED_K = 5.0
#: The paper's reduced calibration set.
FEW_POINTS = 4
_CALIBRATED = ("L0", "p1", "p2", "p3", "p4")


def fit_summary(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None) -> dict[str, Any]:
    """Fit baseline plus ``effects`` to ``data``; the fit, calibration and position-error summary."""
    model = SensorModel(sensor, list(effects))
    result = fit_model(model, data)
    summary: dict[str, Any] = {
        "n_points": len(data),
        "effects": model.effect_names,
        "rmse_ppm": result.rms_ppm,
        "noise_ppm": result.noise_ppm,
        "dof": result.dof,
        "bic": result.bic,
        "converged": result.success,
        "fit_time_s": result.time_s,
        "params": {name: {k: v for k, v in entry.items() if k != "fixed"}
                   for name, entry in result.params_table().items()},
        "fixed": dict(result.fixed),
    }
    calibrations = [_calibration_summary(data, model, result, f) for f in np.unique(data.freq_hz)]
    summary["calibration"] = [c for c in calibrations if c is not None]
    return summary


def _calibration_summary(data: Measurements, model: SensorModel, result: FitResult,
                         freq_hz: float) -> dict[str, Any] | None:
    """Paper-style calibrations at one frequency and the position errors they give, or None."""
    at_f = data.select(data.freq_hz == freq_hz)
    room = room_temperature_rows(at_f)
    finite = np.isfinite(at_f.x_m)
    if len(np.unique(np.round(at_f.x_m[room & finite], 7))) < FEW_POINTS + 1:
        return None
    held = {name: value for name, value in result.values.items() if name not in _CALIBRATED}
    sweep = at_f.select(room)
    coil_rise = at_f.t_coil_c - np.percentile(at_f.t_coil_c, 5)
    target_rise = at_f.t_target_c - np.percentile(at_f.t_target_c[finite], 5)
    coil_hot = finite & (coil_rise > HEATED_K) & (np.abs(target_rise) < HEATED_K)
    target_hot = finite & (target_rise > HEATED_K) & (np.abs(coil_rise) < HEATED_K)
    out: dict[str, Any] = {"freq_hz": float(freq_hz)}
    for label, n_points in (("all_points", None), (f"n{FEW_POINTS}", FEW_POINTS)):
        cal = calibrate(sweep, model.sensor, n_points=n_points, fixed=held, effects=model.effects)
        entry: dict[str, Any] = {
            "n_points": cal.n_points,
            "positions_mm": (cal.positions_m * 1e3).tolist(),
            "fs_mm": cal.fs_m * 1e3,
            "rmse_ppm": cal.fit.rms_ppm,
            "params": {k: v for k, v in cal.fit.params_table().items() if k in _CALIBRATED},
            "room_temperature": _errors(position_errors(cal, at_f.select(room & finite))),
        }
        if coil_hot.any():
            entry["coil_heated"] = _heated(cal, sweep, at_f.select(coil_hot), coil_rise[coil_hot], held,
                                           n_points, model)
        if target_hot.any():
            errors = position_errors(cal, at_f.select(target_hot))
            entry["target_heated"] = _errors(errors, target_rise[target_hot])
        out[label] = entry
    return out


def _heated(cal: Calibration, sweep: Measurements, hot: Measurements, rise: np.ndarray,
            held: dict[str, float], n_points: int | None, model: SensorModel) -> dict[str, Any]:
    """Errors of heated-coil readings with Eq. (4) (compensated) and with alpha = beta = 0."""
    plain = calibrate(sweep, model.sensor, n_points=n_points, fixed={**held, "alpha": 0.0, "beta": 0.0},
                      effects=model.effects)
    compensated = _errors(position_errors(cal, hot), rise)
    uncompensated = _errors(position_errors(plain, hot), rise)
    ratio = compensated["max_abs_mm"] / uncompensated["max_abs_mm"] if uncompensated["max_abs_mm"] else None
    return {"compensated": compensated, "uncompensated": uncompensated, "compensated_ratio": ratio}


def _errors(errors: PositionErrors, rise_k: np.ndarray | None = None) -> dict[str, Any]:
    """Max and RMS position error (mm, % FS), out-of-range count, and TS when temperatures rose."""
    e = errors.error_mm
    out: dict[str, Any] = {
        "n": int(len(e)),
        "max_abs_mm": float(np.max(np.abs(e))),
        "rms_mm": float(np.sqrt(np.mean(e**2))),
        "max_abs_fs_percent": float(np.max(np.abs(errors.error_fs_percent))),
        "out_of_range": int(errors.out_of_range.sum()),
    }
    if rise_k is not None:
        ts = temperature_stability_ppm_fs_per_k(errors.error_m, errors.fs_m, rise_k)
        out.update(delta_t_k=float(np.max(rise_k)), ts_ppm_fs_per_k_min=float(np.min(ts)),
                   ts_ppm_fs_per_k_max=float(np.max(ts)))
    return out


def format_fit_summary(summary: dict[str, Any]) -> str:
    """The summary as text for people: parameters with errors, then each calibration's position errors."""
    effects = ", ".join(summary["effects"]) or "none (baseline)"
    noise = summary.get("noise_ppm")
    lines = [f"Fit of {summary['n_points']} readings, effects: {effects}",
             f"  residual RMS {summary['rmse_ppm']:.2f} ppm"
             + (f" (repeat noise {noise:.2f} ppm)" if noise is not None else "")
             + f", dof {summary['dof']}, BIC {summary['bic']:.1f}", "  parameters:"]
    for name, p in summary["params"].items():
        err = "fixed" if p["stderr"] is None else f"+/- {p['stderr']:.4g}"
        lines.append(f"    {name:<8} {p['value']:>14.7g} {err:<16} {p['unit']}")
    for name, reason in summary.get("fixed", {}).items():
        lines.append(f"    ({name} fixed: {reason})")
    for cal in summary.get("calibration", []):
        lines.append(f"  calibration at {cal['freq_hz']:g} Hz:")
        for label in ("all_points", f"n{FEW_POINTS}"):
            entry = cal[label]
            lines.append(f"    n = {entry['n_points']:>2} (FS {entry['fs_mm']:.0f} mm): room temperature max |e| "
                         f"{entry['room_temperature']['max_abs_mm']:.4f} mm "
                         f"({entry['room_temperature']['max_abs_fs_percent']:.4f} % FS)")
            if "coil_heated" in entry:
                c = entry["coil_heated"]
                lines.append(f"      coil +{c['compensated']['delta_t_k']:.0f} K: max |e| "
                             f"{c['uncompensated']['max_abs_mm']:.3f} mm uncompensated, "
                             f"{c['compensated']['max_abs_mm']:.4f} mm compensated "
                             f"(TS {c['compensated']['ts_ppm_fs_per_k_min']:.1f} .. "
                             f"{c['compensated']['ts_ppm_fs_per_k_max']:.1f} ppm FS/K)")
            if "target_heated" in entry:
                t = entry["target_heated"]
                lines.append(f"      target +{t['delta_t_k']:.0f} K: max |e| {t['max_abs_mm']:.4f} mm "
                             f"({t['max_abs_fs_percent']:.3f} % FS, TS {t['ts_ppm_fs_per_k_min']:.1f} .. "
                             f"{t['ts_ppm_fs_per_k_max']:.1f} ppm FS/K)")
    return "\n".join(lines)
