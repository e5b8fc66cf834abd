"""The `ecds-lab fit --json` summary: model fit, calibration and position errors as one JSON-able dict.

The fit uses all data (baseline plus named effects). Where the data hold a room-temperature
sweep at a frequency, that frequency is calibrated paper-style (all positions and the n = 4
sensitive ones; parameters other than L0 and p1..p4 held at the full fit's values) and the
position errors of room-temperature, coil-heated (with and without Eq. 4) and target-heated
readings are summarised in mm, % FS and ppm FS/K.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ecds_lab.analysis.calibration import (
    Calibration,
    PositionErrors,
    calibrate,
    position_errors,
    room_temperature_rows,
    temperature_stability_ppm_fs_per_k,
)
from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.analysis.noise import noise_parts_text
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.model.sensor_model import SensorModel

#: Temperature rise (K) above room temperature that makes a reading "heated".
HEATED_K = 5.0
#: The paper's reduced calibration set.
FEW_POINTS = 4
_CALIBRATED = ("L0", "p1", "p2", "p3", "p4")


def fit_summary(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None,
                registry: EffectRegistry | None = None) -> dict[str, Any]:
    """Fit baseline plus ``effects`` (from ``registry``, default the library) to ``data``; the fit,
    calibration and position-error summary."""
    model = SensorModel(sensor, list(effects), registry=registry)
    result = fit_model(model, data)
    summary: dict[str, Any] = {
        "n_points": len(data),
        "effects": model.effect_names,
        "rmse_ppm": result.rms_ppm,
        "noise_ppm": round(result.noise.ppm, 3),
        "noise_method": result.noise.method,
        "noise": result.noise.to_json(),
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


@dataclass
class HeatedErrors:
    """Position errors of heated readings and the temperature rise (K) of each."""

    errors: PositionErrors
    rise_k: np.ndarray


@dataclass
class HeatedRows:
    """Readings with the target present taken with the target heated (coil not) or the coil heated (target not).

    Room is each thermocouple's 5th percentile; heated means more than ``HEATED_K`` above it.
    """

    coil: np.ndarray
    target: np.ndarray
    coil_rise_k: np.ndarray
    target_rise_k: np.ndarray
    coil_room_c: float

    @classmethod
    def of(cls, data: Measurements) -> HeatedRows:
        finite = np.isfinite(data.x_m)
        coil_room = float(np.percentile(data.t_coil_c, 5))
        coil_rise = data.t_coil_c - coil_room
        target_rise = (data.t_target_c - np.percentile(data.t_target_c[finite], 5) if finite.any()
                       else np.zeros(len(data)))
        coil = finite & (coil_rise > HEATED_K) & (np.abs(target_rise) < HEATED_K)
        target = finite & (target_rise > HEATED_K) & (np.abs(coil_rise) < HEATED_K)
        return cls(coil, target, coil_rise, target_rise, coil_room)


@dataclass
class CalibrationCase:
    """One paper-style calibration at one frequency and the position errors it gives."""

    label: str
    freq_hz: float
    calibration: Calibration
    room: PositionErrors
    target_heated: HeatedErrors | None = None
    coil_compensated: HeatedErrors | None = None
    coil_uncompensated: HeatedErrors | None = None


def calibration_cases(data: Measurements, model: SensorModel, result: FitResult, freq_hz: float, *,
                      coil_heated: Measurements | None = None) -> list[CalibrationCase]:
    """Calibrations at one frequency with all positions and the n = 4 sensitive ones; [] without a sweep.

    Needs a room-temperature sweep with more than ``FEW_POINTS`` positions. Parameters other than
    L0 and p1..p4 are held at ``result``'s values. Target-heated readings are those with the target
    more than ``HEATED_K`` above room and the coil not; coil-heated ones the reverse, or the
    ``coil_heated`` readings given (e.g. built from a coil-in-air heating run, see
    ``compensation.heated_coil_sweep``), at this frequency.
    """
    at_f = data.select(data.freq_hz == freq_hz)
    room = room_temperature_rows(at_f)
    finite = np.isfinite(at_f.x_m)
    if len(np.unique(np.round(at_f.x_m[room & finite], 7))) < FEW_POINTS + 1:
        return []
    held = {name: value for name, value in result.values.items() if name not in _CALIBRATED}
    sweep = at_f.select(room)
    heated = HeatedRows.of(at_f)
    coil_hot, target_hot, coil_rise, target_rise = heated.coil, heated.target, heated.coil_rise_k, heated.target_rise_k
    if coil_heated is not None:
        hot_coil = coil_heated.select((coil_heated.freq_hz == freq_hz) & np.isfinite(coil_heated.x_m))
        hot_coil_rise = hot_coil.t_coil_c - heated.coil_room_c
    else:
        hot_coil, hot_coil_rise = at_f.select(coil_hot), coil_rise[coil_hot]
    cases = []
    for label, n_points in (("all_points", None), (f"n{FEW_POINTS}", FEW_POINTS)):
        cal = calibrate(sweep, model.sensor, n_points=n_points, fixed=held, effects=model.effects)
        case = CalibrationCase(label, float(freq_hz), cal, position_errors(cal, at_f.select(room & finite)))
        if target_hot.any():
            case.target_heated = HeatedErrors(position_errors(cal, at_f.select(target_hot)), target_rise[target_hot])
        if len(hot_coil):
            plain = calibrate(sweep, model.sensor, n_points=n_points, fixed={**held, "alpha": 0.0, "beta": 0.0},
                              effects=model.effects)
            case.coil_compensated = HeatedErrors(position_errors(cal, hot_coil), hot_coil_rise)
            case.coil_uncompensated = HeatedErrors(position_errors(plain, hot_coil), hot_coil_rise)
        cases.append(case)
    return cases


def _calibration_summary(data: Measurements, model: SensorModel, result: FitResult,
                         freq_hz: float) -> dict[str, Any] | None:
    """Paper-style calibrations at one frequency and the position errors they give, or None."""
    cases = calibration_cases(data, model, result, freq_hz)
    if not cases:
        return None
    out: dict[str, Any] = {"freq_hz": float(freq_hz)}
    for case in cases:
        cal = case.calibration
        entry: dict[str, Any] = {
            "n_points": cal.n_points,
            "positions_mm": (cal.positions_m * 1e3).tolist(),
            "fs_mm": cal.fs_m * 1e3,
            "rmse_ppm": cal.fit.rms_ppm,
            "params": {k: v for k, v in cal.fit.params_table().items() if k in _CALIBRATED},
            "room_temperature": _errors(case.room),
        }
        if case.coil_compensated is not None and case.coil_uncompensated is not None:
            compensated = _errors(case.coil_compensated.errors, case.coil_compensated.rise_k)
            uncompensated = _errors(case.coil_uncompensated.errors, case.coil_uncompensated.rise_k)
            ratio = (compensated["max_abs_mm"] / uncompensated["max_abs_mm"]
                     if uncompensated["max_abs_mm"] else None)
            entry["coil_heated"] = {"compensated": compensated, "uncompensated": uncompensated,
                                    "compensated_ratio": ratio}
        if case.target_heated is not None:
            entry["target_heated"] = _errors(case.target_heated.errors, case.target_heated.rise_k)
        out[case.label] = entry
    return out


def _errors(errors: PositionErrors, rise_k: np.ndarray | None = None) -> dict[str, Any]:
    """Max and RMS position error (mm, % FS), out-of-range count, and TS when temperatures rose."""
    e = errors.error_mm
    out: dict[str, Any] = {
        "n": len(e),
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


def _noise_origin(summary: dict[str, Any]) -> str:
    """Where the noise comes from: its two parts when a slide repeatability was declared, else the method."""
    parts = noise_parts_text(summary.get("noise") or {})
    return f": {parts}" if parts else f", from {summary.get('noise_method', 'the data')}"


def format_fit_summary(summary: dict[str, Any]) -> str:
    """The summary as text for people: parameters with errors, then each calibration's position errors."""
    effects = ", ".join(summary["effects"]) or "none (baseline)"
    noise = summary.get("noise_ppm")
    lines = [f"Fit of {summary['n_points']} readings, effects: {effects}",
             f"  residual RMS {summary['rmse_ppm']:.2f} ppm"
             + (f" (noise {noise:.2f} ppm{_noise_origin(summary)})"
                if noise is not None else "")
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
