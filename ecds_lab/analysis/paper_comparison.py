"""The paper's figures of merit from the demo's run files, side by side with the paper's values.

Each row is ``{"quantity", "paper", "ecds_lab", "unit", "agrees", "how"}`` (DESIGN.md). The
quantities are computed the paper's way (Gruber et al. 2024): sensitivity S = dL/dx from a
room-temperature sweep, position error e_pos = dL / S of a heated sweep against the room sweep
(Sec. 3.3, 4.3), temperature stability TS = e_pos / (FS dT) with FS = 100 mm (Table 1), the
Eq. (4) coil compensation fitted to the coil's steady states in air, calibrations with n = 31 and
n = 4 points (Sec. 5), and parallel RLC fits of the spectra (Table 2). "agrees" means inside the
paper's stated bound, or within a factor of 1.5 of an approximate value; rows that cannot agree
say why in "how".
"""

from __future__ import annotations

import math
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.storage.data_file import open_data

#: Full scale of the paper's sensor (Table 1: range 100 mm).
FS_M = 0.100
#: Approximate paper values agree within this factor.
APPROX_FACTOR = 1.5

Row = dict[str, Any]


def _row(quantity: str, paper: Any, value: float | None, unit: str, agrees: bool, how: str, why: str = "") -> Row:
    """One row; ``why`` (the reason the lab cannot agree) is added to ``how`` when it does not."""
    shown = None if value is None or not math.isfinite(value) else float(f"{value:.4g}")
    if not agrees and why:
        how = f"{how}. Differs because {why}"
    return {"quantity": quantity, "paper": paper, "ecds_lab": shown, "unit": unit, "agrees": bool(agrees), "how": how}


def _approx(value: float, paper: float) -> bool:
    return math.isfinite(value) and paper / APPROX_FACTOR <= value <= paper * APPROX_FACTOR


def _sweep_l(data: Measurements, freq: float, t_target_c: float | None = None, band_k: float = 3.0,
             direction: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Mean Ls per position of the readings at one frequency (optionally near a target temperature)."""
    rows = (data.freq_hz == freq) & np.isfinite(data.x_m)
    if t_target_c is not None:
        rows &= np.abs(data.t_target_c - t_target_c) <= band_k
    if direction is not None:
        rows &= data.direction == direction
    x = np.round(data.x_m[rows], 6)
    positions = np.unique(x)
    return positions, np.array([data.ls_h[rows][x == p].mean() for p in positions])


def _sensitivity(x: np.ndarray, ls: np.ndarray) -> np.ndarray:
    return np.gradient(ls, x)


def heating_errors_m(data: Measurements, freq: float) -> tuple[np.ndarray, np.ndarray, float]:
    """e_pos(x) = (L_hot - L_room) / S of the hottest target sweep against the room one; and its dT."""
    steps = np.round(data.t_target_c[np.isfinite(data.x_m)] / 5.0) * 5.0
    cold_t, hot_t = float(steps.min()), float(steps.max())
    x_c, l_c = _sweep_l(data, freq, cold_t, 4.0)
    x_h, l_h = _sweep_l(data, freq, hot_t, 4.0)
    common = np.intersect1d(x_c, x_h)
    lc, lh = l_c[np.isin(x_c, common)], l_h[np.isin(x_h, common)]
    return common, (lh - lc) / _sensitivity(common, lc), hot_t - cold_t


def sensitivity_rows(copper: Measurements, steel: Measurements) -> list[Row]:
    """Copper vs steel dL/dx at 15 kHz over 20-30 mm (Sec. 2.2.2, Fig. 7)."""
    x_c, l_c = _sweep_l(copper, 15000.0, direction=1)
    x_s, l_s = _sweep_l(steel, 15000.0, t_target_c=float(np.min(steel.t_target_c)), band_k=3.0)
    def slope(x: np.ndarray, ls: np.ndarray) -> float:
        i20, i30 = np.argmin(abs(x - 0.020)), np.argmin(abs(x - 0.030))
        return float((ls[i30] - ls[i20]) / (x[i30] - x[i20]))
    ratio = slope(x_c, l_c) / slope(x_s, l_s)
    return [_row("copper vs steel sensitivity dL/dx, 15 kHz, 20-30 mm", "≈1.7 (copper ≈70 % higher)", ratio, "ratio",
                 1.3 <= ratio <= 2.2, "(L(30 mm) - L(20 mm)) / 10 mm from the room-temperature sweeps (copper "
                 "displacement sweep, steel target-heating sweep at room temperature); agrees within 1.3-2.2")]


def target_rows(copper: Measurements, steel: Measurements | None) -> list[Row]:
    """Target heating: position errors at 500 Hz and 15 kHz, range in % FS, TS, steel vs copper."""
    rows: list[Row] = []
    x, e500, dt = heating_errors_m(copper, 500.0)
    _, e15k, _ = heating_errors_m(copper, 15000.0)
    max500, max15k = float(np.max(np.abs(e500))), float(np.max(np.abs(e15k)))
    how = (f"e_pos = (L_hot - L_room) / S over the sweep, copper plate {dt:.0f} K above room (paper Sec. 3.3)")
    rows.append(_row(f"copper target heated {dt:.0f} K, 500 Hz, max |e_pos|", "≈0.15 (Fig. 15)", max500 * 1e3, "mm",
                     _approx(max500 * 1e3, 0.15), how))
    rows.append(_row(f"copper target heated {dt:.0f} K, 15 kHz, max |e_pos|", "< 0.1 (Fig. 14)", max15k * 1e3, "mm",
                     max15k * 1e3 < 0.1, how))
    below = x < 0.050
    sign15 = float(np.mean(e15k[below])) if below.any() else math.nan
    rows.append(_row("copper target heated, 15 kHz, mean e_pos below 50 mm (bending)", "negative (Fig. 14)",
                     sign15 * 1e3, "mm", sign15 < 0, "the hot plate bends toward the coil: negative error near it"))
    both = np.concatenate([e500, e15k]) / FS_M * 100
    lo, hi = float(both.min()), float(both.max())
    rows.append(_row(f"target ΔT {dt:.0f} K, e_pos range, 500 Hz and 15 kHz", "-0.12 … 0.2 (Fig. 22)",
                     None, "% FS", lo >= -0.12 and hi <= 0.2,
                     f"ecds-lab: {lo:.3f} … {hi:.3f} % FS (FS = 100 mm); inside the paper's range to agree")
                | {"ecds_lab": [round(lo, 4), round(hi, 4)]})
    ts_lo, ts_hi = lo / 100 / dt * 1e6, hi / 100 / dt * 1e6
    rows.append(_row(f"target ΔT {dt:.0f} K, temperature stability TS", "-11 … 18 (Table 1)", None, "ppm FS/K",
                     ts_lo >= -11 and ts_hi <= 18, f"TS = e_pos / (FS ΔT): {ts_lo:.1f} … {ts_hi:.1f} ppm FS/K")
                | {"ecds_lab": [round(ts_lo, 2), round(ts_hi, 2)]})
    if steel is not None:
        _, es, dts = heating_errors_m(steel, 15000.0)
        ratio = float(np.max(np.abs(es))) / max15k
        rows.append(_row("steel vs copper target-heating error, 15 kHz", "≈10 (Fig. 14)", ratio, "ratio",
                         _approx(ratio, 10.0), f"max |e_pos| of the steel plate {dts:.0f} K above room over the "
                         f"copper plate's {dt:.0f} K (the paper's steel rise was also about 30 % of copper's)",
                         "the lab's steel follows the paper's Sec. 3.1 law (sigma 5 -> 3 MS/m, mu_r 100 -> 200 over "
                         "100 K), so mu_r/sigma, which sets a magnetic plate's screening at 15 kHz, rises by a third "
                         "at 55 C; the paper's measured steel error implies a plate whose properties changed less "
                         "(that law was the bound of a simulation study)"))
    return rows


def _steady_air(air: Measurements, freq: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean (T_coil, Ls) of each steady coil temperature in air at one frequency."""
    from ecds_lab.analysis.compensation import steady_coil_steps

    at_f = air.select((air.freq_hz == freq) & ~np.isfinite(air.x_m))
    steps = steady_coil_steps(at_f)
    return (np.array([at_f.t_coil_c[s].mean() for s in steps]), np.array([at_f.ls_h[s].mean() for s in steps]))


def coil_rows(air: Measurements, room: Measurements) -> list[Row]:
    """Coil heated in air, 500 Hz: position error uncompensated and with Eq. (4) (Sec. 4.3, Fig. 20, 23)."""
    rows: list[Row] = []
    t, l_air = _steady_air(air, 500.0)
    keep = t <= t.min() + 110.0
    t, l_air = t[keep], l_air[keep]
    d_t = t - t[0]
    coeffs = np.polyfit(d_t, l_air / l_air[0], 2)  # Eq. (4): 1 + alpha dT + beta dT^2 (fitted constant ~1)
    model = np.polyval(coeffs, d_t) * l_air[0]
    x, l_x = _sweep_l(room, 500.0, direction=1)
    s = _sensitivity(x, l_x)
    # Sec. 4.3: L(T) = L_coil(T) (1 - k~(x)): the air coil's relative change scales the sweep's L(x).
    rel_unc = (l_air / l_air[0] - 1.0)[:, None]
    rel_comp = ((l_air - model) / l_air[0])[:, None]
    e_unc = rel_unc * l_x[None, :] / s[None, :]
    e_comp = rel_comp * l_x[None, :] / s[None, :]
    span = float(d_t.max())
    max_comp = float(np.max(np.abs(e_comp)))
    how = (f"steady coil temperatures in air up to {span:.0f} K above room, Eq. (4) fitted to them; "
           "e_pos = (dL_coil / L_coil) L(x) / S(x) with L(x), S(x) from the room sweep (paper Sec. 4.3)")
    rows.append(_row(f"coil heated {span:.0f} K, 500 Hz, compensated with Eq. 4, max |e_pos|", "< 0.2 (Fig. 23)",
                     max_comp / FS_M * 100, "% FS", max_comp / FS_M * 100 < 0.2, how))
    ts = max_comp / FS_M / span * 1e6
    rows.append(_row(f"coil heated {span:.0f} K, 500 Hz, compensated, TS", "< 22 (Table 1)", ts, "ppm FS/K", ts < 22,
                     "TS = max |e_pos| / (FS ΔT)"))
    ratio = max_comp / float(np.max(np.abs(e_unc)))
    rows.append(_row("compensated / uncompensated coil error, 500 Hz", "≈0.1 (Fig. 20)", ratio, "ratio",
                     _approx(ratio, 0.1), "max |e_pos| with Eq. (4) over max |e_pos| without",
                     "the lab's coil at 500 Hz changes only by expansion and an early drying shrinkage, which "
                     "Eq. (4) follows closely; the paper's moist formers also changed between heat cycles "
                     "(hysteresis, Sec. 4.2), which the lab's moisture does not reproduce"))
    first = air.select((air.freq_hz == 15000.0) & ~np.isfinite(air.x_m))
    l15 = float(np.mean(first.ls_h[:3]))
    rows.append(_row("coil in air, 15 kHz, L", "≈57 (Sec. 2.2)", l15 * 1e3, "mH", _approx(l15 * 1e3, 57.0),
                     "first readings of the coil in air at room temperature; the simulated winding's L in air "
                     "comes from its geometry (Dodd & Deeds), the former's C raises the apparent L at 15 kHz"))
    return rows


def calibration_rows(room: Measurements) -> list[Row]:
    """n = 4 vs n = 31 calibration points (Sec. 5, Fig. 21/22): RMS position error on the whole sweep."""
    from ecds_lab.analysis.calibration import calibrate, position_errors

    at15 = room.select(room.freq_hz == 15000.0)
    rms = {}
    for n in (None, 4):
        cal = calibrate(at15, n_points=n)
        err = position_errors(cal, at15).error_m
        rms[n] = float(np.sqrt(np.mean(err**2)))
    ratio = rms[4] / rms[None]
    return [_row("n = 4 vs n = 31 calibration, 15 kHz, RMS e_pos ratio", "≈1 (about the same, Fig. 22)", ratio,
                 "ratio", _approx(ratio, 1.0), f"Eq. (5)-(6) calibrations on the room sweep; RMS e_pos over the "
                 f"whole sweep: n = 31 {rms[None] * 1e6:.1f} um, n = 4 {rms[4] * 1e6:.1f} um")]


TABLE_2 = {20.0: (61e-3, 62.5e-12, 92e3), 65.0: (60.4e-3, 47.46e-12, 212e3), 120.0: (58.4e-3, 47.53e-12, 984e3)}


def table2_rows(spectroscopy: Measurements) -> list[Row]:
    """Parallel RLC fits of the moist coil's spectra while heating, against Table 2."""
    from ecds_lab.analysis.spectroscopy import fit_parallel_rlc

    rows: list[Row] = []
    fits = []
    starts = np.flatnonzero(np.diff(spectroscopy.freq_hz) < 0) + 1
    bounds = [0, *starts.tolist(), len(spectroscopy)]
    for a, b in pairwise(bounds):
        part = spectroscopy.select((np.arange(len(spectroscopy)) >= a) & (np.arange(len(spectroscopy)) < b))
        fit = fit_parallel_rlc(part.freq_hz, part.ls_h, part.rs_ohm)
        fits.append((float(np.mean(part.t_coil_c)), fit))
    for t_paper, (l_p, c_p, r_p) in TABLE_2.items():
        t, fit = min(fits, key=lambda item: abs(item[0] - t_paper))
        where = f"parallel RLC fit of the spectrum at {t:.0f} °C (analysis.spectroscopy)"
        dl = fit.inductance_h / l_p - 1
        rows.append(_row(f"Table 2 L_p at {t_paper:.0f} °C", round(l_p * 1e3, 4), fit.inductance_h * 1e3, "mH",
                         abs(dl) < 0.05, where + "; within 5 % to agree",
                         "the lab's L is the winding's geometric L (Dodd & Deeds, "
                         "the paper's nominal 110-150 mm x 3 mm, 500 turns: 53.6 mH), which moves only with expansion; "
                         "the paper's prototype has randomly distributed turns and its L_p falls 4 % on drying, "
                         "which a lumped C and loss across the winding does not produce"))
        dc = fit.capacitance_f / c_p - 1
        rows.append(_row(f"Table 2 C_p at {t_paper:.0f} °C", round(c_p * 1e12, 4), fit.capacitance_f * 1e12, "pF",
                         abs(dc) < 0.1, where + "; within 10 % to agree"))
        rows.append(_row(f"Table 2 R_p at {t_paper:.0f} °C", round(r_p * 1e-3, 4), fit.parallel_resistance_ohm * 1e-3,
                         "kΩ", _approx(fit.parallel_resistance_ohm, r_p), where + "; within a factor 1.5 to agree",
                         "the lab's former loss is dielectric (conductance growing with frequency) while the fit "
                         "assumes a constant R_p, and the lab's drying at the spectroscopy's hold times does not "
                         "follow the paper's exactly"))
    return rows


#: The demo's run files (stems) the rows are computed from.
RUN_STEMS = ("displacement_sweep", "coil_heating", "spectroscopy", "target_heating_copper", "target_heating_steel")


def paper_comparison(run_files: list[Path]) -> list[Row]:
    """Every row the demo's run files allow (found by the names the demo gives them)."""
    return compare({p.stem: open_data(p).data for p in run_files if p.stem in RUN_STEMS})


def compare(runs: dict[str, Measurements]) -> list[Row]:
    """Every row the given recordings allow, keyed by the demo's run names (``RUN_STEMS``)."""
    room, air = runs.get("displacement_sweep"), runs.get("coil_heating")
    spectroscopy = runs.get("spectroscopy")
    copper, steel = runs.get("target_heating_copper"), runs.get("target_heating_steel")
    rows: list[Row] = []
    if room is not None and steel is not None:
        rows += sensitivity_rows(room, steel)
    if copper is not None:
        rows += target_rows(copper, steel)
    if air is not None and room is not None:
        rows += coil_rows(air, room)
    if room is not None:
        rows += calibration_rows(room)
    if spectroscopy is not None:
        rows += table2_rows(spectroscopy)
    return rows
