"""The live page's plots, drawn on the server as PNG (matplotlib's Agg backend, no display needed)."""

from __future__ import annotations

import io
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.live.snapshot import Snapshot
from ecds_lab.storage.reader import read_measurements

#: Refit at most this often (s): a fit takes a fraction of a second, the page polls every second.
REFIT_S = 5.0


class ModelCache:
    """The model fitted to what the file held at the last refit (None until enough points)."""

    def __init__(self) -> None:
        self._at, self._rows = 0.0, 0
        self._fit: tuple[Measurements, np.ndarray] | None = None

    def predicted_ls(self, snap: Snapshot) -> tuple[Measurements, np.ndarray] | None:
        """(the readings fitted, model Ls at each) from the last fit, refitted when due."""
        rows = len(snap.points)
        if rows != self._rows and time.monotonic() - self._at > REFIT_S and rows >= 8:
            self._at, self._rows = time.monotonic(), rows
            try:
                from ecds_lab.analysis.fitting import fit

                data = read_measurements(snap.path)
                if np.isfinite(data.x_m).sum() >= 8:
                    result = fit(data, sensor=None)
                    self._fit = (data, data.ls_h / (1 + result.residuals_ppm * 1e-6))
            except Exception:  # too few or odd points so far: plot the readings alone
                self._fit = None
        return self._fit


def _png(fig: plt.Figure) -> bytes:
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=90)
    plt.close(fig)
    return out.getvalue()


def groups(snap: Snapshot) -> list[tuple[str, np.ndarray]]:
    """(label, row mask) per frequency and thermal step: a heating run's sweeps apart, named by temperature."""
    x, ls, freq = snap.column("x_commanded_mm"), snap.column("ls_h"), snap.column("freq_hz")
    shown = np.isfinite(ls) & np.isfinite(plot_axis(snap)[0])
    heated = snap.column("t_target_c" if snap.kind == "target_heating" else "t_coil_c")
    passes = snap.column("sweep") if snap.kind.endswith("heating") and np.isfinite(x).any() else np.zeros(len(x))
    out = []
    for f in np.unique(freq[shown]):
        for p in np.unique(passes[shown & (freq == f)]):
            mask = shown & (freq == f) & (passes == p)
            step = "" if not passes.any() else f", {np.nanmean(heated[mask]):.0f} °C" if p >= 0 else ", while heating"
            label = f"{f:g} Hz{step}"
            out.append((label, mask))
    return out


def plot_axis(snap: Snapshot) -> tuple[np.ndarray, str]:
    """x when the run has positions, else time (a coil in air, a spectrum at one place)."""
    x = snap.column("x_commanded_mm")
    if np.isfinite(x).any():
        return x, "distance x (mm)"
    return snap.column("time_s"), "time in run (s)"


def plotted_points(snap: Snapshot) -> int:
    """How many readings the inductance plot shows."""
    return int(sum(mask.sum() for _, mask in groups(snap))) if len(snap.points) else 0


def inductance_png(snap: Snapshot, model: ModelCache) -> bytes:
    """L(x) per frequency and thermal step (L(t) without positions), with the model fitted so far as lines."""
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    if len(snap.points):
        axis, label = plot_axis(snap)
        ls = snap.column("ls_h")
        for name, mask in groups(snap):
            ax.plot(axis[mask], ls[mask] * 1e3, "o", ms=3, label=name)
        fitted = model.predicted_ls(snap) if label.startswith("distance") else None
        if fitted is not None:
            data, predicted = fitted
            for f in np.unique(data.freq_hz):
                m = (data.freq_hz == f) & np.isfinite(data.x_mm)
                order = np.argsort(data.x_mm[m])
                ax.plot(data.x_mm[m][order], predicted[m][order] * 1e3, "-", lw=1, color="k", alpha=0.6)
            ax.plot([], [], "-", color="k", alpha=0.6, label="model fitted so far")
        ax.set_xlabel(label)
        ax.legend(fontsize=7, ncol=2)
    ax.set_ylabel("Ls (mH)")
    ax.set_title(f"inductance: {len(snap.points)} rows")
    return _png(fig)


def temperatures_png(snap: Snapshot) -> bytes:
    """Temperatures and heater powers against time."""
    fig, ax = plt.subplots(figsize=(7, 3.4), layout="constrained")
    if len(snap.points):
        t = snap.column("time_s") / 60.0
        for name in ("t_coil_c", "t_target_c", "t_ambient_c"):
            ax.plot(t, snap.column(name), label=name)
        power = ax.twinx()
        for name, style in (("coil_heater_w", ":"), ("target_heater_w", "--")):
            values = snap.column(name)
            if np.isfinite(values).any():
                power.plot(t, values, style, color="0.3", label=name)
        power.set_ylabel("heater power (W)")
        power.legend(fontsize=7, loc="lower right")
        ax.legend(fontsize=7, loc="upper left")
    ax.set_xlabel("time in run (min)")
    ax.set_ylabel("temperature (°C)")
    return _png(fig)
