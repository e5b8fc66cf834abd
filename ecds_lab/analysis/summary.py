"""The `ecds-lab fit --json` summary: model fit, calibration and position errors as one JSON-able dict.

The fit uses all data (baseline plus named effects). Where the data hold a room-temperature
sweep at a frequency, that frequency is calibrated paper-style (all positions and the n = 4
sensitive ones; parameters other than L0 and p1..p4 held at the full fit's values) and the
position errors of room-temperature, coil-heated (without and with the paper's Eq. (4) per
frequency from the steady in-air points) and target-heated readings are summarised in mm, % FS
and ppm FS/K. The report reads the same ``calibration_cases``, figures and keys, so both show one
number per quantity; every figure knows its limits (``quantities.position_error_figure``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ecds_lab.analysis.blas_threads import one_blas_thread
from ecds_lab.analysis.calibration import (
    Calibration,
    PositionErrors,
    calibrate,
    position_errors,
    room_temperature_rows,
    temperature_stability_ppm_fs_per_k,
)
from ecds_lab.analysis.compensation import SteadyEq4, fit_steady_eq4, heated_coil_sweep
from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.analysis.noise import REPEATED, noise_parts_text
from ecds_lab.analysis.quantities import (
    MODEL_FAILS,
    MODEL_FAILS_FACTOR,
    VALID,
    PositionErrorFigure,
    format_quantity,
    model_fails,
    params_json,
    position_error_figure,
)
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.model.sensor_model import SensorModel

#: Temperature rise (K) above room temperature that makes a reading "heated".
HEATED_K = 5.0
#: The paper's reduced calibration set.
FEW_POINTS = 4
_CALIBRATED = ("L0", "p1", "p2", "p3", "p4")
#: What the paper-style calibrations take from the full fit, said wherever that fit fails: its parameters give no
#: positions themselves, the calibrations' positions stand or fall with the calibrations' own residuals.
CALIBRATIONS_FROM_FIT = ("its parameters describe no coil and give no positions of their own; each calibration "
                         "refits L0 and p1..p4 on its room-temperature sweep, holds the others at this fit's values "
                         f"and gives positions only while its own residual stays within {MODEL_FAILS_FACTOR:g}x "
                         "the noise")
#: The Eq. (4) coefficients of the joint model fit (every reading, every frequency), named where shown.
JOINT_EQ4_METHOD = "alpha, beta of the joint model fit of every reading at every frequency"


def fit_summary(data: Measurements, effects: Sequence[str] = (), sensor: SensorConfig | None = None,
                registry: EffectRegistry | None = None) -> dict[str, Any]:
    """Fit baseline plus ``effects`` (from ``registry``, default the library) to ``data``; the fit,
    calibration and position-error summary. On one BLAS thread, as the diagnosis (``search.run_diagnosis``)."""
    with one_blas_thread():
        return _fit_summary(data, effects, sensor, registry)


def _fit_summary(data: Measurements, effects: Sequence[str], sensor: SensorConfig | None,
                 registry: EffectRegistry | None) -> dict[str, Any]:
    """``fit_summary``'s work."""
    model = SensorModel(sensor, list(effects), registry=registry)
    result = fit_model(model, data)
    summary: dict[str, Any] = {
        "n_points": len(data),
        "effects": model.effect_names,
        "rmse_ppm": result.rms_ppm,
        "noise_ppm": round(result.noise.ppm, 3),
        "noise_method": result.noise.method,
        "noise": result.noise.to_json(),
        "noise_warnings": list(result.noise.warnings),
        "dof": result.dof,
        "bic": result.bic,
        "converged": result.success,
        "fit_time_s": result.time_s,
        "model": _model_status(result),
        "params": params_json(result),
        "fixed": dict(result.fixed),
    }
    coil = CoilInputs.of(data, model.sensor.reference_temperature_c)
    calibrations = [_calibration_summary(data, model, result, f, coil) for f in np.unique(data.freq_hz)]
    summary["calibration"] = [c for c in calibrations if c is not None]
    summary["quantities"] = _quantities(summary["calibration"], model.sensor.target)
    for e in coil.eq4.values():
        summary["quantities"][f"eq4.alpha_per_k.{e.freq_hz:g}Hz"] = e.alpha_per_k
    summary["eq4_steady"] = [{"freq_hz": e.freq_hz, "method": e.method, "reference_c": e.reference_c,
                              "alpha_per_k": e.alpha_per_k, "beta_per_k2": e.beta_per_k2, "l0_h": e.l0_h,
                              "span_k": e.span_k, "glitches_excluded": e.glitches_excluded}
                             for e in coil.eq4.values()]
    return summary


def _quantities(calibrations: list[dict[str, Any]], material: str) -> dict[str, float | None]:
    """Every max |e_pos| of the calibrations under its one key (``quantity_key``), FS and Eq. (4) alike."""
    out: dict[str, float | None] = {}
    for cal in calibrations:
        f = cal["freq_hz"]
        for label in ("all_points", f"n{FEW_POINTS}"):
            entry = cal[label]
            out[f"full_scale_mm.{material}.{f:g}Hz"] = entry["fs_mm"]
            out[quantity_key("room", material, f, label)] = entry["room_temperature"]["max_abs_mm"]
            out[rms_key(quantity_key("room", material, f, label))] = entry["room_temperature"]["rms_mm"]
            heated = {"target_heated": entry.get("target_heated")}
            if "coil_heated" in entry:
                heated.update({f"coil_{kind}": entry["coil_heated"][kind] for kind in ("compensated", "uncompensated")})
            for kind, figure in heated.items():
                if figure is None:
                    continue
                key = quantity_key(kind, material, f, label)
                out[key] = figure["max_abs_mm"]
                if "ts_ppm_fs_per_k_min" in figure:
                    out[ts_key(key, "min")] = figure["ts_ppm_fs_per_k_min"]
                    out[ts_key(key, "max")] = figure["ts_ppm_fs_per_k_max"]
    return out


def rms_key(error_key: str) -> str:
    """The key of the RMS position error that goes with a max |e_pos| figure's key."""
    return error_key.replace("position_error.max_abs_mm", "position_error.rms_mm")


def ts_key(error_key: str, end: str) -> str:
    """The key of the TS (min or max) that goes with a max |e_pos| figure's key."""
    return error_key.replace("position_error.max_abs_mm", "ts_ppm_fs_per_k") + f".{end}"


@dataclass
class CoilInputs:
    """What the coil-in-air readings give the calibrations: the paper's Eq. (4) per frequency
    (``compensation.fit_steady_eq4``) and, when no reading has the coil heated with the target present,
    heated-coil sweeps built the paper's way (``compensation.heated_coil_sweep``)."""

    eq4: dict[float, SteadyEq4]
    heated: Measurements | None = None

    @classmethod
    def of(cls, data: Measurements, reference_c: float) -> CoilInputs:
        air = data.select(data.in_air)
        eq4 = {float(f): e for f in np.unique(air.freq_hz)
               if (e := fit_steady_eq4(air, float(f), reference_c)) is not None}
        heated = None
        if len(air) and not HeatedRows.of(data).coil.any() and np.isfinite(data.x_m).any():
            sweep = data.select(room_temperature_rows(data) & np.isfinite(data.x_m))
            built = heated_coil_sweep(sweep, air)
            heated = built if len(built) else None
        return cls(eq4, heated)


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
    compensation_method: str = JOINT_EQ4_METHOD
    #: The noise (ppm) the calibration's residual is judged against (``judging_noise_ppm``).
    noise_ppm: float | None = None


def judging_noise_ppm(calibration: FitResult, full: FitResult) -> float:
    """The noise a calibration's residual is judged against ("model fails here" above 10x): its own when
    repeated readings measured it, else the full fit's when they measured that. A noise taken from the
    calibration's own residual (a short sweep without repeats) is that residual's spread, against which no
    residual can ever fail: the steel sweep at 15 kHz (9 positions) judged 405 ppm against its own 473 ppm."""
    if calibration.noise.method != REPEATED and full.noise.method == REPEATED:
        return full.noise.ppm
    return calibration.noise.ppm


def calibration_cases(data: Measurements, model: SensorModel, result: FitResult, freq_hz: float, *,
                      coil: CoilInputs | None = None) -> list[CalibrationCase]:
    """Calibrations at one frequency with all positions and the n = 4 sensitive ones; [] without a sweep.

    Needs a room-temperature sweep with more than ``FEW_POINTS`` positions. Parameters other than
    L0 and p1..p4 are held at ``result``'s values. Target-heated readings are those with the target
    more than ``HEATED_K`` above room and the coil not; coil-heated ones the reverse, or the
    heated-coil readings ``coil`` built from a coil-in-air heating run, at this frequency.
    Eq. (4) compensation holds alpha and beta at the paper's per-frequency fit to the steady
    coil temperatures in air (``coil.eq4``) when there is one at this frequency, else at the
    joint fit's; the case says which (``compensation_method``).
    """
    at_f = data.select(data.freq_hz == freq_hz)
    room = room_temperature_rows(at_f)
    finite = np.isfinite(at_f.x_m)
    if len(np.unique(np.round(at_f.x_m[room & finite], 7))) < FEW_POINTS + 1:
        return []
    held = {name: value for name, value in result.values.items() if name not in _CALIBRATED}
    solved = {name: result.values[name] for name in _CALIBRATED}  # where the calibrations start (shared work)
    sweep = at_f.select(room)
    heated = HeatedRows.of(at_f)
    coil_hot, target_hot, coil_rise, target_rise = heated.coil, heated.target, heated.coil_rise_k, heated.target_rise_k
    coil_heated = coil.heated if coil is not None else None
    eq4 = coil.eq4.get(float(freq_hz)) if coil is not None else None
    if coil_heated is not None:
        hot_coil = coil_heated.select((coil_heated.freq_hz == freq_hz) & np.isfinite(coil_heated.x_m))
        hot_coil_rise = hot_coil.t_coil_c - heated.coil_room_c
    else:
        hot_coil, hot_coil_rise = at_f.select(coil_hot), coil_rise[coil_hot]
    cases = []
    for label, n_points in (("all_points", None), (f"n{FEW_POINTS}", FEW_POINTS)):
        cal = calibrate(sweep, model.sensor, n_points=n_points, fixed=held, effects=model.effects, start=solved)
        case = CalibrationCase(label, float(freq_hz), cal, position_errors(cal, at_f.select(room & finite)),
                               noise_ppm=judging_noise_ppm(cal.fit, result))
        if target_hot.any():
            case.target_heated = HeatedErrors(position_errors(cal, at_f.select(target_hot)), target_rise[target_hot])
        if len(hot_coil):
            # Other alpha, beta on the same room-temperature sweep: the same valley, from the calibration's solution.
            start = {name: cal.fit.values[name] for name in _CALIBRATED}
            plain = calibrate(sweep, model.sensor, n_points=n_points, fixed={**held, "alpha": 0.0, "beta": 0.0},
                              effects=model.effects, start=start)
            compensated = cal
            if eq4 is not None:
                compensated = calibrate(sweep, model.sensor, n_points=n_points, effects=model.effects, start=start,
                                        fixed={**held, "alpha": eq4.alpha_per_k, "beta": eq4.beta_per_k2})
                case.compensation_method = eq4.method
            case.coil_compensated = HeatedErrors(position_errors(compensated, hot_coil), hot_coil_rise)
            case.coil_uncompensated = HeatedErrors(position_errors(plain, hot_coil), hot_coil_rise)
        cases.append(case)
    return cases


def _calibration_summary(data: Measurements, model: SensorModel, result: FitResult,
                         freq_hz: float, coil: CoilInputs | None = None) -> dict[str, Any] | None:
    """Paper-style calibrations at one frequency and the position errors they give, or None."""
    cases = calibration_cases(data, model, result, freq_hz, coil=coil)
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
            "params": {k: v for k, v in params_json(cal.fit).items() if k in _CALIBRATED},
            "room_temperature": _errors(case.room, fit=cal.fit, noise_ppm=case.noise_ppm),
        }
        if case.coil_compensated is not None and case.coil_uncompensated is not None:
            compensated = _errors(case.coil_compensated.errors, case.coil_compensated.rise_k, cal.fit, case.noise_ppm)
            uncompensated = _errors(case.coil_uncompensated.errors, case.coil_uncompensated.rise_k, cal.fit,
                                    case.noise_ppm)
            ratio = (compensated["max_abs_mm"] / uncompensated["max_abs_mm"]
                     if compensated["max_abs_mm"] is not None and uncompensated["max_abs_mm"] else None)
            entry["coil_heated"] = {"compensated": compensated, "uncompensated": uncompensated,
                                    "compensated_ratio": ratio, "compensation_method": case.compensation_method,
                                    "built_from_air": coil is not None and coil.heated is not None}
        if case.target_heated is not None:
            entry["target_heated"] = _errors(case.target_heated.errors, case.target_heated.rise_k, cal.fit,
                                             case.noise_ppm)
        out[case.label] = entry
    return out


def _model_status(fit: FitResult) -> dict[str, str]:
    """``{"status": "valid"}``, or ``model fails here`` with the reason (residual far above the noise)."""
    failure = model_fails(fit.rms_ppm, fit.noise.ppm)
    return {"status": MODEL_FAILS, "reason": failure} if failure else {"status": VALID}


def quantity_key(kind: str, material: str, freq_hz: float, label: str) -> str:
    """The one name of a max |e_pos| figure (kind: room, target_heated, coil_uncompensated, coil_compensated),
    the same in the fit JSON's ``quantities`` and the report's marked cells."""
    return f"position_error.max_abs_mm.{kind}.{material}.{freq_hz:g}Hz.{label}"


def in_range(errors: PositionErrors) -> np.ndarray:
    """Readings the calibration speaks for (``PositionErrors.in_range``)."""
    return errors.in_range


def heated_figure(heated: HeatedErrors, calibration: Calibration,
                  noise_ppm: float | None = None) -> PositionErrorFigure:
    """The position-error figure of heated readings under a calibration (``quantities.position_error_figure``),
    its residual judged against ``noise_ppm`` (the case's ``noise_ppm``; default the calibration's own noise)."""
    return _figure(heated.errors, calibration.fit, noise_ppm)


#: TS is quoted over the readings of the highest temperature step: rises above this share of the largest.
TOP_STEP_SHARE = 0.8
TS_OVER = f"in-range readings of the highest temperature step (rise >= {TOP_STEP_SHARE:.0%} of the largest)"


def temperature_stability_top_step(errors: PositionErrors, rise_k: np.ndarray) -> tuple[float, float] | None:
    """(min, max) TS in ppm FS/K over the in-range readings of the highest temperature step, the one TS every
    output quotes; None without such readings. Lower steps are left out: a small rise divides the noise into
    a large, meaningless TS."""
    if not len(rise_k):
        return None
    top = in_range(errors) & (rise_k >= TOP_STEP_SHARE * float(np.max(rise_k)))
    if not top.any():
        return None
    ts = temperature_stability_ppm_fs_per_k(errors.error_m[top], errors.fs_m, rise_k[top])
    return float(np.min(ts)), float(np.max(ts))


def _figure(errors: PositionErrors, fit: FitResult | None, noise_ppm: float | None = None) -> PositionErrorFigure:
    if noise_ppm is None and fit is not None:
        noise_ppm = fit.noise.ppm
    return position_error_figure(errors.error_mm, errors.fs_m * 1e3, errors.out_of_range,
                                 model_rms_ppm=fit.rms_ppm if fit is not None else None, noise_ppm=noise_ppm)


def _errors(errors: PositionErrors, rise_k: np.ndarray | None = None, fit: FitResult | None = None,
            noise_ppm: float | None = None) -> dict[str, Any]:
    """Max and RMS position error (mm, % FS) over the readings in range, their status, and TS when temperatures rose.

    ``max_abs_mm`` is None when the figure is not a length (all readings out of range, or the
    calibration's model fails: ``quantities.position_error_figure``); out-of-range readings are
    counted in ``out_of_range`` and left out of every figure.
    """
    figure = _figure(errors, fit, noise_ppm)
    out = figure.to_json()
    out["text"] = figure.text()
    if rise_k is not None:
        out["delta_t_k"] = float(np.max(rise_k)) if len(rise_k) else None
        ts = temperature_stability_top_step(errors, rise_k) if figure.valid else None
        if ts is not None:
            out.update(ts_ppm_fs_per_k_min=ts[0], ts_ppm_fs_per_k_max=ts[1], ts_over=TS_OVER)
    return out


def _noise_origin(summary: dict[str, Any]) -> str:
    """Where the noise comes from: its two parts when a slide repeatability was declared, else the method."""
    parts = noise_parts_text(summary.get("noise") or {})
    return f": {parts}" if parts else f", from {summary.get('noise_method', 'the data')}"


def _ts_text(entry: dict[str, Any]) -> str:
    if "ts_ppm_fs_per_k_min" not in entry:
        return ""
    return f", TS {entry['ts_ppm_fs_per_k_min']:.1f} .. {entry['ts_ppm_fs_per_k_max']:.1f} ppm FS/K"


def format_fit_summary(summary: dict[str, Any]) -> str:
    """The summary as text for people: parameters with errors and status, then each calibration's position errors.

    Every figure is the JSON's (``quantities``' formatting); a position error that is not a length
    (out of range, model fails) is printed as such, and out-of-range readings are named.
    """
    effects = ", ".join(summary["effects"]) or "none (baseline)"
    noise = summary.get("noise_ppm")
    lines = [f"Fit of {summary['n_points']} readings, effects: {effects}",
             f"  residual RMS {summary['rmse_ppm']:.2f} ppm"
             + (f" (noise {noise:.2f} ppm{_noise_origin(summary)})"
                if noise is not None else "")
             + f", dof {summary['dof']}, BIC {summary['bic']:.1f}"]
    model = summary.get("model", {})
    if model.get("status") == MODEL_FAILS:
        lines.append(f"  {MODEL_FAILS}: {model['reason']}; {CALIBRATIONS_FROM_FIT} (ecds-lab diagnose finds what "
                     "the model lacks)")
    lines += [f"  warning: {text}" for text in summary.get("noise_warnings", [])]
    lines.append("  parameters:")
    width = max([14, *(len(name) for name in summary["params"])])
    for name, p in summary["params"].items():
        shown = p.get("shown") or format_quantity(p["value"], p["unit"], p["stderr"])
        status = p.get("status", "")
        reason = f" ({p['status_reason']})" if p.get("status_reason") else ""
        lines.append(f"    {name:<{width}} {shown:<26} {status}{reason}")
    for cal in summary.get("calibration", []):
        lines.append(f"  calibration at {cal['freq_hz']:g} Hz:")
        for label in ("all_points", f"n{FEW_POINTS}"):
            entry = cal[label]
            room = entry["room_temperature"]
            lines.append(f"    n = {entry['n_points']:>2} (FS {entry['fs_mm']:.4g} mm): room temperature max |e| "
                         f"{room['text']}")
            if "coil_heated" in entry:
                c = entry["coil_heated"]
                lines.append(f"      coil +{c['compensated']['delta_t_k']:.0f} K: max |e| "
                             f"{c['uncompensated']['text']} uncompensated, "
                             f"{c['compensated']['text']} compensated{_ts_text(c['compensated'])}")
            if "target_heated" in entry:
                t = entry["target_heated"]
                lines.append(f"      target +{t['delta_t_k']:.0f} K: max |e| {t['text']}{_ts_text(t)}")
    return "\n".join(lines)
