"""Figures of temperature effects: position errors of heated target and coil (Fig. 14/20/22/23),
the coil's heating characterisation with Eq. (4) (Fig. 17/19), and spectroscopy (Fig. 18)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import Colormap, Normalize

from ecds_lab.analysis.compensation import SteadyEq4, TemperatureCompensation
from ecds_lab.analysis.spectroscopy import RlcFit
from ecds_lab.analysis.summary import CalibrationCase, HeatedErrors
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.ecm import parallel_rlc_impedance
from ecds_lab.report.canvas import Png, colormap, colour_scale, grid, styled, subplots, to_png
from ecds_lab.report.figures_model import STATE_BIN_K

#: Line style per calibration: all positions solid, the paper's n = 4 dashed.
CALIBRATION_STYLE = {"all_points": ("-", "o"), "n4": ("--", "^")}
#: Position-error panels: size, and margins that leave room for the labels and the % FS axis (inches).
PANEL_W_IN, PANEL_H_IN, KEY_W_IN = 4.3, 2.6, 1.0
MARGINS = {"left": 0.75, "right": 0.55, "bottom": 0.5, "top": 0.3, "gap_w": 1.55, "gap_h": 0.75}
#: Rate of the coil temperature (K/min) above which a reading counts as heating (below minus: cooling).
RAMP_K_PER_MIN = 0.3


def calibration_label(case: CalibrationCase) -> str:
    return f"n = {case.calibration.n_points}"


def _error_lines(ax: Axes, case: CalibrationCase, heated: HeatedErrors, norm: Normalize, cmap: Colormap) -> None:
    """One line per temperature step: the mean error at each reference position over the readings in range
    (a reading out of range has no error to draw), coloured by the rise."""
    line, marker = CALIBRATION_STYLE.get(case.label, ("-", "o"))
    errors = heated.errors
    steps = np.round(heated.rise_k / STATE_BIN_K)
    inside = errors.in_range
    for step in np.unique(steps[inside]):
        sel = (steps == step) & inside
        x, index = np.unique(np.round(errors.x_ref_m[sel] * 1e3, 4), return_inverse=True)
        mean = np.bincount(index, errors.error_mm[sel]) / np.bincount(index)
        colour = cmap(norm(float(np.mean(heated.rise_k[sel]))))
        ax.plot(x, mean, line, marker=marker, ms=3, mfc="none" if line != "-" else colour, color=colour, lw=1.0)


def _fs_axis(ax: Axes, fs_m: float) -> None:
    """A right-hand axis in % of full scale."""
    fs_mm = fs_m * 1e3
    right = ax.secondary_yaxis("right", functions=(lambda mm: np.asarray(mm) / fs_mm * 100,
                                                       lambda pct: np.asarray(pct) * fs_mm / 100))
    right.set_ylabel("e_pos (% FS)")


def _style_key(ax: Axes, cases: Sequence[CalibrationCase]) -> None:
    for case in cases:
        line, marker = CALIBRATION_STYLE.get(case.label, ("-", "o"))
        ax.plot([], [], line, marker=marker, color="0.3", mfc="none" if line != "-" else "0.3",
                label=calibration_label(case) + " calibration")
    ax.legend(loc="best", frameon=True, framealpha=0.85)


@styled
def target_heating_errors(panels: Sequence[tuple[str, float, list[CalibrationCase]]]) -> Png:
    """Fig. 14/22: position error of target-heated readings against x, per frequency (rows) and target (columns)."""
    materials = sorted({m for m, _, _ in panels}, key=lambda m: (m != "copper", m))
    freqs = sorted({f for _, f, _ in panels})
    fig, axes, key = grid(PANEL_W_IN, PANEL_H_IN, len(freqs), len(materials), key_w=KEY_W_IN, **MARGINS)
    rises = np.concatenate([c.target_heated.rise_k for _, _, cases in panels for c in cases if c.target_heated])
    norm, cmap = Normalize(0.0, float(np.max(rises))), colormap("plasma")
    for ax in axes.flat:
        ax.set_axis_off()
        ax.text(0.5, 0.5, "not calibrated at this frequency\n(see the note above)", ha="center", va="center",
                color="0.45", transform=ax.transAxes)
    for material, freq, cases in panels:
        ax = axes[freqs.index(freq), materials.index(material)]
        ax.set_axis_on()
        ax.texts[0].remove()
        for case in cases:
            if case.target_heated is not None:
                _error_lines(ax, case, case.target_heated, norm, cmap)
        _error_axes(ax, f"{material} target, {freq:g} Hz", cases)
    fig.colorbar(colour_scale(norm, cmap), cax=key, label="target temperature rise Δϑ_T (K)")
    return to_png(fig, "Position error of target-heated readings against distance")


@styled
def coil_heating_errors(panels: Sequence[tuple[float, list[CalibrationCase]]]) -> Png:
    """Fig. 20/23: position error of coil-heated readings, uncompensated (left) and with Eq. (4) (right)."""
    fig, axes, key = grid(PANEL_W_IN, PANEL_H_IN, len(panels), 2, key_w=KEY_W_IN, **MARGINS)
    rises = np.concatenate([c.coil_compensated.rise_k for _, cases in panels for c in cases if c.coil_compensated])
    norm, cmap = Normalize(0.0, float(np.max(rises))), colormap("inferno_r")
    for row, (freq, cases) in enumerate(panels):
        for col, (title, pick) in enumerate((("uncompensated", lambda c: c.coil_uncompensated),
                                              ("compensated with Eq. (4)", lambda c: c.coil_compensated))):
            ax = axes[row, col]
            for case in cases:
                if pick(case) is not None:
                    _error_lines(ax, case, pick(case), norm, cmap)
            _error_axes(ax, f"{freq:g} Hz, {title}", cases)
    fig.colorbar(colour_scale(norm, cmap), cax=key, label="coil temperature rise Δϑ_coil (K)")
    return to_png(fig, "Position error of coil-heated readings, uncompensated and compensated")


def _error_axes(ax: Axes, title: str, cases: Sequence[CalibrationCase]) -> None:
    """Zero line, title, labels, the % FS axis and the calibration key of a position-error panel."""
    ax.axhline(0.0, color="0.4", lw=0.6)
    ax.set_title(title)
    ax.set_xlabel("reference position x (mm)")
    ax.set_ylabel("position error e_pos (mm)")
    _fs_axis(ax, cases[0].calibration.fs_m)
    _style_key(ax, cases)


def _air_grid(freq_hz: float, t_coil_c: np.ndarray) -> Measurements:
    n = len(t_coil_c)
    return Measurements(time_s=np.arange(n, dtype=float), x_m=np.full(n, np.inf), freq_hz=np.full(n, freq_hz),
                        t_coil_c=t_coil_c, t_target_c=np.full(n, 20.0), ls_h=np.ones(n), rs_ohm=np.ones(n),
                        source="model grid")


@styled
def coil_heating(air: Measurements, compensation: TemperatureCompensation,
                 steady: Mapping[float, SteadyEq4] | None = None) -> Png:
    """Fig. 17/19: change of the air coil's inductance with temperature, the joint Eq. (4) fit and its residual,
    and the paper's Eq. (4) per frequency through the steady points (``steady``), each labelled by its method."""
    freqs = air.frequencies_hz
    fig, axes = subplots(4.6 * len(freqs), 5.6, 2, len(freqs), sharex="col", height_ratios=(2.2, 1.0))
    rate = air.coil_temperature_rate_k_per_s() * 60.0
    residual = compensation.fit.residuals_ppm
    ref = compensation.reference_c
    for col, freq in enumerate(freqs):
        at_f = air.freq_hz == freq
        l_ref = float(compensation.fit.predict(_air_grid(float(freq), np.array([ref])))[0])
        grid_t = np.linspace(min(ref, float(np.min(air.t_coil_c))), float(np.max(air.t_coil_c)), 200)
        model = compensation.fit.predict(_air_grid(float(freq), grid_t))
        top, bottom = axes[0, col], axes[1, col]
        for label, sel, colour in (("heating", rate > RAMP_K_PER_MIN, "tab:red"),
                                   ("cooling", rate < -RAMP_K_PER_MIN, "tab:blue"),
                                   ("steady", np.abs(rate) <= RAMP_K_PER_MIN, "0.15")):
            rows = at_f & sel
            top.plot(air.t_coil_c[rows], (air.ls_h[rows] - l_ref) * 1e6, "o", ms=3, mfc="none", color=colour,
                     label=f"measured, {label}")
            bottom.plot(air.t_coil_c[rows], residual[rows], "o", ms=3, mfc="none", color=colour)
        top.plot(grid_t, (model - l_ref) * 1e6, "-", color="tab:green", lw=1.5, label="Eq. (4), joint model fit")
        eq4 = (steady or {}).get(float(freq))
        if eq4 is not None:
            top.plot(eq4.t_coil_c, (eq4.ls_h - l_ref) * 1e6, "s", ms=6, color="tab:purple", label="steady points")
            top.plot(grid_t, (eq4.l0_h * eq4.factor(grid_t) - l_ref) * 1e6, "--", color="tab:purple", lw=1.5,
                     label="Eq. (4) through them (the paper's)")
        top.set_title(f"coil in air, {freq:g} Hz")
        top.set_ylabel(f"ΔL_coil (µH) vs fit at {ref:g} °C")
        top.legend(frameon=False)
        bottom.axhline(0.0, color="0.4", lw=0.6)
        bottom.set_ylabel("residual of the joint fit (ppm)")
        bottom.set_xlabel("coil temperature ϑ_coil (°C)")
    return to_png(fig, "Change of the coil inductance in air with temperature and the fit of Eq. (4)")


@styled
def spectra(items: Sequence[tuple[Measurements, RlcFit]]) -> Png:
    """Fig. 18: |Z| and phase of the coil in air against frequency per temperature, with the RLC fits."""
    fig, axes = subplots(11.0, 3.8, 1, 2)
    temps = [float(np.mean(d.t_coil_c)) for d, _ in items]
    norm = Normalize(min(temps), max(max(temps), min(temps) + 1.0))
    cmap = colormap("plasma")
    markers = "osD^v<>p"
    for k, ((data, fit), temp) in enumerate(zip(items, temps, strict=True)):
        colour = cmap(0.85 * norm(temp))
        marker = markers[k % len(markers)]
        omega = 2 * np.pi * data.freq_hz
        z = data.rs_ohm + 1j * omega * data.ls_h
        f = np.geomspace(float(np.min(data.freq_hz)), float(np.max(data.freq_hz)), 400)
        zf = parallel_rlc_impedance(2 * np.pi * f, fit.inductance_h, fit.capacitance_f, fit.parallel_resistance_ohm,
                                    fit.series_resistance_ohm)
        label = f"{temp:.0f} °C"
        axes[0, 0].plot(data.freq_hz, np.abs(z) / 1e3, marker, ms=4, mfc="none", color=colour,
                        label=f"{label} measured")
        axes[0, 0].plot(f, np.abs(zf) / 1e3, "--", color=colour, lw=1.2, label=f"{label} parallel RLC fit")
        axes[0, 1].plot(data.freq_hz, np.degrees(np.angle(z)), marker, ms=4, mfc="none", color=colour)
        axes[0, 1].plot(f, np.degrees(np.angle(zf)), "--", color=colour, lw=1.2)
    for ax in axes[0]:
        ax.set_xscale("log")
        ax.set_xlabel("frequency (Hz)")
    axes[0, 0].set_yscale("log")
    axes[0, 0].set_ylabel("|Z| (kΩ)")
    axes[0, 0].legend(frameon=False, ncol=1)
    axes[0, 1].set_ylabel("phase of Z (°)")
    axes[0, 0].set_title("impedance magnitude")
    axes[0, 1].set_title("impedance phase")
    return to_png(fig, "Impedance spectroscopy of the coil in air with parallel RLC fits")
