"""The live page's plots, drawn on the server as PNG (matplotlib's Agg backend, no display needed)."""

from __future__ import annotations

import io
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ecds_lab.live.snapshot import Snapshot
from ecds_lab.storage.reader import read_measurements

#: Refit at most this often (s): a fit takes a fraction of a second, the page polls every second.
REFIT_S = 5.0


class ModelCache:
    """The model fitted to what the file held at the last refit (None until enough points)."""

    def __init__(self) -> None:
        self._at, self._rows, self._fit = 0.0, 0, None

    def predicted_ls(self, snap: Snapshot) -> tuple[np.ndarray, np.ndarray] | None:
        """(row mask of fitted readings, model Ls at them) from the last fit, refitted when due."""
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
        return self._fit  # type: ignore[return-value]


def _png(fig: plt.Figure) -> bytes:
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=90)
    plt.close(fig)
    return out.getvalue()


def inductance_png(snap: Snapshot, model: ModelCache) -> bytes:
    """L(x) per frequency and thermal step, with the model fitted so far as lines."""
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    if len(snap.points):
        x, ls, freq = snap.column("x_commanded_mm"), snap.column("ls_h"), snap.column("freq_hz")
        step_t = np.round(snap.column("t_coil_c") / 10.0) * 10.0 if snap.kind.endswith("heating") else None
        finite_x = np.isfinite(x)
        axis = x if finite_x.any() else snap.column("time_s")
        for f in np.unique(freq[np.isfinite(freq)]):
            groups = np.unique(step_t[freq == f]) if step_t is not None else [None]
            for t in groups:
                mask = (freq == f) & np.isfinite(ls) & np.isfinite(axis) & (True if t is None else step_t == t)
                label = f"{f:g} Hz" + ("" if t is None else f", ~{t:g} °C")
                ax.plot(axis[mask], ls[mask] * 1e6, "o", ms=3, label=label)
        fitted = model.predicted_ls(snap) if finite_x.any() else None
        if fitted is not None:
            data, predicted = fitted
            for f in np.unique(data.freq_hz):
                m = data.freq_hz == f
                order = np.argsort(data.x_mm[m])
                ax.plot(data.x_mm[m][order], predicted[m][order] * 1e6, "-", lw=1, color="k", alpha=0.6)
            ax.plot([], [], "-", color="k", alpha=0.6, label="model fitted so far")
        ax.set_xlabel("distance x (mm)" if finite_x.any() else "time in run (s)")
        ax.legend(fontsize=7, ncol=2)
    ax.set_ylabel("Ls (µH)")
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
                power.plot(t, values, style, label=name)
        power.set_ylabel("heater power (W)")
        ax.legend(fontsize=7, loc="upper left")
    ax.set_xlabel("time in run (min)")
    ax.set_ylabel("temperature (°C)")
    return _png(fig)
