"""Figures of the model fit: L(x) with the fitted model (Fig. 6), sensitivity (Fig. 7), residual maps
and the diagnosis (candidate ranking, residuals before and after the best effect)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure

from ecds_lab.analysis.fitting import FitResult
from ecds_lab.data.columns import VARIABLES, Variable
from ecds_lab.data.measurements import Measurements
from ecds_lab.report.canvas import Png, colormap, colour_scale, styled, subplots, to_png

#: Readings of one state are within this many kelvin (target and coil) of each other.
STATE_BIN_K = 5.0
#: A state is drawn as a curve when it has readings at this many positions or more.
MIN_CURVE_POSITIONS = 5
#: Sensitivity needs a room-temperature sweep over at least this many positions.
MIN_SENSITIVITY_POSITIONS = 3
GREY = "0.6"
MATERIAL_MARKERS = {"copper": "o", "aluminium": "D", "brass": "v", "steel": "s"}
CATEGORY_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink")


def category_colour(index: int) -> str:
    """The colour of the index-th value of a categorical variable (the palette repeats)."""
    return CATEGORY_COLOURS[index % len(CATEGORY_COLOURS)]


#: Abscissae of the residual maps; each is coloured by every other variable (and frequency).
MAP_AXES = ("x_mm", "t_coil_c", "t_target_c", "time_s", "direction")
MAP_COLOURS = ("x_mm", "t_coil_c", "t_target_c", "time_s", "direction", "freq_hz")


def states(data: Measurements) -> list[np.ndarray]:
    """Row indices of each thermal state (target and coil temperature within STATE_BIN_K), coolest first."""
    key = np.round(data.t_target_c / STATE_BIN_K) * 1000 + np.round(data.t_coil_c / STATE_BIN_K)
    return [np.flatnonzero(key == k) for k in np.unique(key)]


def _grid(freq_hz: float, t_coil_c: float, t_target_c: float, x_mm: np.ndarray) -> Measurements:
    """Stand-in readings over distances at one frequency and thermal state, for evaluating the model."""
    n = len(x_mm)
    return Measurements(time_s=np.arange(n, dtype=float), x_m=np.asarray(x_mm) * 1e-3, freq_hz=np.full(n, freq_hz),
                        t_coil_c=np.full(n, t_coil_c), t_target_c=np.full(n, t_target_c), ls_h=np.ones(n),
                        rs_ohm=np.ones(n), source="model grid")


def model_grid(fit: FitResult, freq_hz: float, t_coil_c: float, t_target_c: float,
               x_mm: np.ndarray) -> np.ndarray:
    """The fitted model's Ls (H) over distances at one frequency and thermal state."""
    return fit.predict(_grid(freq_hz, t_coil_c, t_target_c, x_mm))


def model_sensitivity_grid(fit: FitResult, freq_hz: float, t_coil_c: float, t_target_c: float,
                           x_mm: np.ndarray) -> np.ndarray:
    """The fitted model's dLs/dx (H/m) over distances at one frequency and thermal state."""
    return fit.model.sensitivity(_grid(freq_hz, t_coil_c, t_target_c, x_mm), fit.values)


def _state_label(material: str, rows: Measurements) -> str:
    return (f"{material}, target {np.mean(rows.t_target_c):.0f} °C, "
            f"coil {np.mean(rows.t_coil_c):.0f} °C")


@styled
def inductance_vs_distance(groups: Sequence[tuple[str, FitResult, Measurements]]) -> Png:
    """Fig. 6: measured L(x) per frequency and thermal state, the fitted model over it."""
    freqs = np.unique(np.concatenate([d.freq_hz[np.isfinite(d.x_m)] for _, _, d in groups]))
    fig, axes = subplots(4.6 * len(freqs) + 1.8, 4.2, 1, len(freqs), sharey=False)
    all_t = np.concatenate([d.t_target_c for _, _, d in groups])
    norm = Normalize(float(np.min(all_t)), max(float(np.max(all_t)), float(np.min(all_t)) + 1.0))
    cmap = colormap("plasma")
    for ax, freq in zip(axes[0], freqs, strict=True):
        for material, fit, data in groups:
            part = data.select(np.isfinite(data.x_m) & (data.freq_hz == freq))
            marker = MATERIAL_MARKERS.get(material, "^")
            for rows in states(part):
                state = part.select(rows)
                positions = np.unique(np.round(state.x_mm, 4))
                colour = cmap(norm(np.mean(state.t_target_c)))
                if len(positions) < MIN_CURVE_POSITIONS:
                    ax.plot(state.x_mm, state.ls_h * 1e3, marker, ms=2.5, color=GREY, alpha=0.6, ls="none")
                    continue
                ax.plot(state.x_mm, state.ls_h * 1e3, marker, ms=3.5, mfc="none", color=colour, ls="none",
                        label=_state_label(material, state))
                x = np.linspace(positions.min(), positions.max(), 120)
                model = model_grid(fit, float(freq), float(np.mean(state.t_coil_c)),
                                   float(np.mean(state.t_target_c)), x)
                ax.plot(x, model * 1e3, "-", color=colour, lw=1.0)
        ax.set_title(f"{freq:g} Hz: measured (markers), fitted model (lines)")
        ax.set_xlabel("distance x (mm)")
        ax.set_ylabel("inductance L (mH)")
    fig.colorbar(colour_scale(norm, cmap), ax=axes[0, -1], label="target temperature (°C)", shrink=0.9)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if labels:
        axes[0, 0].legend(handles[:12], labels[:12], loc="lower right", frameon=False)
    return to_png(fig, "Measured inductance against distance per frequency, with the fitted model")


def room_sweep_positions(data: Measurements) -> int:
    """The most distinct positions of a room-temperature sweep at any one frequency."""
    from ecds_lab.analysis.calibration import room_temperature_rows

    room = data.select(room_temperature_rows(data) & np.isfinite(data.x_m))
    return max((len(np.unique(np.round(room.x_mm[room.freq_hz == f], 4))) for f in room.frequencies_hz), default=0)


@styled
def sensitivity(groups: Sequence[tuple[str, FitResult, Measurements]]) -> Png:
    """Fig. 7: S = dL/dx at room temperature per frequency: model (lines), measured differences (markers)."""
    from ecds_lab.analysis.calibration import room_temperature_rows

    freqs = np.unique(np.concatenate([d.freq_hz[np.isfinite(d.x_m)] for _, _, d in groups]))
    fig, axes = subplots(4.4 * len(freqs), 3.6, 1, len(freqs))
    for ax, freq in zip(axes[0], freqs, strict=True):
        for (material, fit, data), colour in zip(groups, CATEGORY_COLOURS, strict=False):
            room = data.select(room_temperature_rows(data) & np.isfinite(data.x_m) & (data.freq_hz == freq))
            if not len(room):
                continue
            positions, index = np.unique(np.round(room.x_mm, 4), return_inverse=True)
            if len(positions) < MIN_SENSITIVITY_POSITIONS:
                continue
            mean_l = np.bincount(index, room.ls_h) / np.bincount(index)
            measured = np.gradient(mean_l, positions * 1e-3)
            ax.plot(positions, measured * 1e3, MATERIAL_MARKERS.get(material, "^"), ms=3.5, mfc="none",
                    color=colour, label=f"{material}: measured (finite differences)")
            x = np.linspace(positions.min(), positions.max(), 200)
            slope = model_sensitivity_grid(fit, float(freq), float(np.mean(room.t_coil_c)),
                                           float(np.mean(room.t_target_c)), x)
            ax.plot(x, slope * 1e3, "-", color=colour, lw=1.2, label=f"{material}: model")
        ax.set_title(f"sensitivity at {freq:g} Hz, room temperature")
        ax.set_xlabel("distance x (mm)")
        ax.set_ylabel("S = dL/dx (µH/mm)")
        ax.legend(frameon=False)
    return to_png(fig, "Sensitivity dL/dx against distance per frequency")


#: Residual map rows: panel height, space below for the axis label, above for the colour keys (inches).
ROW_PANEL_IN, ROW_BOTTOM_IN, KEYS_IN, ROW_TOP_IN = 1.55, 0.45, 0.95, 0.12


@styled
def residual_map_row(data: Measurements, residuals_ppm: np.ndarray, noise_ppm: float | None, axis_name: str,
                     keys: bool) -> Png:
    """One row of the residual maps: residual (ppm of L) against ``axis_name``, one panel per colour variable.

    Rows drawn separately line up (same width and margins) and share the residual axis; the
    colour keys (one per column) are drawn above the row with ``keys``. The panel whose colour
    would repeat its own axis is drawn in one colour.
    """
    cols = len(MAP_COLOURS)
    height = ROW_PANEL_IN + ROW_BOTTOM_IN + (KEYS_IN if keys else ROW_TOP_IN)
    fig, axes = subplots(2.05 * cols, height, 1, cols, sharey=True, layout=None,
                         gridspec_kw={"left": 0.055, "right": 0.99, "bottom": ROW_BOTTOM_IN / height,
                                      "top": 1 - (KEYS_IN if keys else ROW_TOP_IN) / height, "wspace": 0.12})
    r = np.asarray(residuals_ppm, float)
    values = {name: VARIABLES[name].display(data) for name in MAP_COLOURS}
    scales = _colour_scales(values)
    cmap = colormap("viridis")
    jitter = np.random.default_rng(0).uniform(-0.18, 0.18, len(data))
    x = values[axis_name] + (jitter if VARIABLES[axis_name].categorical else 0.0)
    span = float(np.max(np.abs(r))) * 1.05 if len(r) else 1.0
    for ax, colour_name in zip(axes[0], MAP_COLOURS, strict=True):
        if colour_name == axis_name:
            ax.scatter(x, r, s=3, color="0.35", lw=0)
        else:
            _coloured_scatter(ax, x, r, values[colour_name], VARIABLES[colour_name], scales.get(colour_name), cmap)
        if noise_ppm:
            ax.axhspan(-noise_ppm, noise_ppm, color="0.86", zorder=0, lw=0)
        ax.axhline(0.0, color="0.4", lw=0.6, zorder=1)
        ax.set_ylim(-span, span)
        ax.locator_params(axis="x", nbins=4)
        ax.set_xlabel(VARIABLES[axis_name].label, fontsize=7.5, labelpad=1)
        ax.tick_params(labelsize=7, pad=1)
        if axis_name == "direction":
            ax.set_xticks([-1, 0, 1], ["−", "0", "+"])
    axes[0, 0].set_ylabel("residual (ppm)", fontsize=7.5)
    if keys:
        _colour_keys(fig, axes[0], values, scales, cmap, KEYS_IN / height)
    return to_png(fig, f"Residual in ppm against {VARIABLES[axis_name].label}, coloured by each recorded variable")


def _colour_scales(values: dict[str, np.ndarray]) -> dict[str, Normalize]:
    scales = {}
    for name, v in values.items():
        c = v[np.isfinite(v)]
        if not VARIABLES[name].categorical and len(c):
            scales[name] = Normalize(float(np.min(c)), max(float(np.max(c)), float(np.min(c)) + 1e-9))
    return scales


def _colour_keys(fig: Figure, axes: Sequence[Axes], values: dict[str, np.ndarray], scales: dict[str, Normalize],
                 cmap: Colormap, room: float) -> None:
    """A colour bar (continuous) or legend (categorical) above each column."""
    for ax, colour_name in zip(axes, MAP_COLOURS, strict=False):
        variable = VARIABLES[colour_name]
        if colour_name in scales:
            box = ax.get_position()
            bar_ax = fig.add_axes((box.x0, box.y1 + 0.28 * room, box.width, 0.07 * room))
            bar = fig.colorbar(colour_scale(scales[colour_name], cmap), cax=bar_ax, orientation="horizontal")
            bar.ax.tick_params(labelsize=6.5, pad=1)
            bar.ax.xaxis.set_ticks_position("top")
            bar.ax.locator_params(nbins=4)
            bar_ax.set_title(f"colour: {variable.label}", fontsize=7.5, pad=12)
        else:
            known = np.unique(values[colour_name][np.isfinite(values[colour_name])])
            handles = [ax.scatter([], [], s=12, color=category_colour(i)) for i in range(len(known))]
            labels = [_category_label(variable, v) for v in known]
            ax.legend(handles, labels, loc="lower center", bbox_to_anchor=(0.5, 1.02), ncol=max(len(labels), 1),
                      frameon=False, fontsize=7, handletextpad=0.1, columnspacing=0.6,
                      title=f"colour: {variable.label}", title_fontsize=7.5)


def _category_label(variable: Variable, value: float) -> str:
    if variable.name == "direction":
        return {1: "+ (increasing x)", -1: "− (decreasing x)"}.get(int(value), "none")
    return f"{value:g}"


def _coloured_scatter(ax: Axes, x: np.ndarray, y: np.ndarray, c: np.ndarray, variable: Variable,
                      norm: Normalize | None, cmap: Colormap) -> None:
    """Scatter coloured by a variable: fixed colours for a categorical one, ``norm`` and ``cmap`` otherwise;
    rows without a value (coil in air has no distance) are grey."""
    known = np.isfinite(c) & np.isfinite(x)
    unknown = ~np.isfinite(c) & np.isfinite(x)
    if unknown.any():
        ax.scatter(x[unknown], y[unknown], s=3, color=GREY, lw=0)
    if variable.categorical:
        for i, value in enumerate(np.unique(c[known])):
            sel = known & (c == value)
            ax.scatter(x[sel], y[sel], s=3, color=category_colour(i), lw=0)
    elif known.any():
        ax.scatter(x[known], y[known], s=3, c=c[known], cmap=cmap, norm=norm, lw=0)


@styled
def candidate_ranking(effects: Sequence[str], rms_ppm: Sequence[float], delta_bic: Sequence[float],
                      baseline_rms_ppm: float, noise_ppm: float) -> Png:
    """The diagnosis' candidates: residual RMS and delta BIC (best first, at the top)."""
    n = len(effects)
    fig, axes = subplots(9.5, 1.0 + 0.38 * n, 1, 2, sharey=True)
    y = np.arange(n)[::-1]
    colours = ["tab:green" if i == 0 and delta_bic[0] < 0 else "tab:blue" for i in range(n)]
    ax = axes[0, 0]
    ax.barh(y, rms_ppm, color=colours, height=0.6)
    ax.axvline(baseline_rms_ppm, color="tab:red", lw=1.2, ls="--", label=f"baseline {baseline_rms_ppm:.1f} ppm")
    ax.axvline(noise_ppm, color="0.2", lw=1.2, ls=":", label=f"noise {noise_ppm:.1f} ppm")
    ax.set_yticks(y, effects)
    ax.set_xlabel("residual RMS with the effect added (ppm of L)")
    ax.set_xlim(0, 1.08 * max(max(rms_ppm), baseline_rms_ppm, noise_ppm))
    ax.legend(loc="lower right", frameon=True, framealpha=0.9)
    ax = axes[0, 1]
    ax.barh(y, delta_bic, color=colours, height=0.6)
    ax.axvline(0.0, color="0.3", lw=0.8)
    ax.set_xlabel("ΔBIC against the baseline (< 0: effect supported)")
    return to_png(fig, "Diagnosis: candidate effects ranked by residual RMS and delta BIC")


#: Panels of a before/after figure.
STEP_PANELS = 3
#: A variable with at most this many distinct values is binned by value, else into this many quantile bins.
SIGNATURE_BINS = 48


def explained_share(values: np.ndarray, change: np.ndarray, groups: np.ndarray) -> float:
    """Share of the variance of ``change`` (about its mean in each group) that the means over bins of
    ``values`` explain, less the share bins explain by chance ((bins - 1) / readings). Readings where the
    variable has no value (x of the coil in air) explain nothing: variables are compared on every reading."""
    total = explained = 0.0
    for g in np.unique(groups):
        rows = (groups == g) & np.isfinite(change)
        if rows.sum() < 3:
            continue
        c = change[rows] - np.mean(change[rows])
        v = values[rows]
        known = np.isfinite(v)
        total += float(c @ c)
        if known.sum() < 3:
            continue
        v, ck = v[known], c[known]
        distinct = np.unique(v)
        if len(distinct) <= SIGNATURE_BINS:
            index = np.searchsorted(distinct, v)
        else:
            edges = np.quantile(v, np.linspace(0, 1, SIGNATURE_BINS + 1)[1:-1])
            index = np.searchsorted(edges, v)
        counts = np.bincount(index)
        means = np.bincount(index, ck) / np.where(counts > 0, counts, 1)
        between = float(np.sum(counts * means**2))
        bins = int((counts > 0).sum())
        explained += max(0.0, between - (bins - 1) / len(c) * float(c @ c))
    return explained / total if total > 0 else 0.0


def signature_variables(data: Measurements, before_ppm: np.ndarray, after_ppm: np.ndarray,
                        telling: Sequence[str] = (), panels: int = STEP_PANELS) -> list[str]:
    """The variables a before/after figure shows: first the two where the added effect's signature lives
    (the variables whose bins, within each frequency, explain most of the residual's change), then the
    ``telling`` ones (e.g. where the final residual lives), up to ``panels``."""
    change = np.asarray(before_ppm, float) - np.asarray(after_ppm, float)
    scores = {name: explained_share(variable.values(data), change, data.freq_hz)
              for name, variable in VARIABLES.items() if name != "freq_hz"}
    ranked = sorted(scores, key=lambda name: -scores[name])
    chosen = ranked[:2] if panels > 2 else ranked[:1]
    for name in [*telling, *ranked]:
        if name in VARIABLES and name not in chosen:
            chosen.append(name)
    return chosen[:panels]


@styled
def before_after(data: Measurements, before_ppm: np.ndarray, after_ppm: np.ndarray, effect: str,
                 variables: Sequence[str], noise_ppm: float | None, previous: str = "baseline") -> Png:
    """Residuals of the previous model (named ``previous``) and of it plus ``effect`` against ``variables``
    (the first is where the effect's signature lives, see ``signature_variables``)."""
    names = [v for v in variables if v in VARIABLES][:STEP_PANELS] or ["x_mm"]
    fig, axes = subplots(4.0 * len(names), 3.4, 1, len(names), sharey=True)
    jitter = np.random.default_rng(1).uniform(-0.18, 0.18, len(data))
    for ax, name in zip(axes[0], names, strict=True):
        variable = VARIABLES[name]
        x = variable.display(data) + (jitter if variable.categorical else 0.0)
        if noise_ppm:
            ax.axhspan(-noise_ppm, noise_ppm, color="0.88", zorder=0, lw=0, label="± noise")
        ax.scatter(x, before_ppm, s=5, color="tab:red", alpha=0.45, lw=0, label=previous)
        ax.scatter(x, after_ppm, s=5, color="tab:blue", alpha=0.7, lw=0, label=f"+ {effect}")
        ax.axhline(0.0, color="0.4", lw=0.6)
        ax.set_xlabel(variable.label)
        if name == "freq_hz":
            ax.set_xscale("log")
        if name == "direction":
            ax.set_xticks([-1, 0, 1], ["−", "0", "+"])
    axes[0, 0].set_ylabel("residual (ppm of L)")
    axes[0, 0].legend(loc="upper left", frameon=True, framealpha=0.9, markerscale=2.0)
    return to_png(fig, f"Residuals before and after adding {effect}")
