"""Impedance spectroscopy (paper Table 2): fit (R_s + jwL) || C || R_p to a sweep over frequency.

The bridge reports series values (Ls, Rs) per frequency; the fit works on the complex
impedance Z = Rs + jw Ls with residuals relative to |Z| (the bridge's noise is relative
to |Z|), L, C and R_p in log space and R_s in units of its start.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ecds_lab.data.measurements import Measurements
from ecds_lab.model.ecm import parallel_rlc_impedance, self_resonance_hz

_NAMES = ("inductance_h", "capacitance_f", "parallel_resistance_ohm", "series_resistance_ohm")


@dataclass
class RlcFit:
    """Fitted parallel RLC circuit with standard errors; residual RMS in ppm of |Z|."""

    inductance_h: float
    capacitance_f: float
    parallel_resistance_ohm: float
    series_resistance_ohm: float
    stderr: dict[str, float]
    rms_ppm: float
    t_coil_c: float = math.nan

    @property
    def resonance_hz(self) -> float:
        return float(self_resonance_hz(self.inductance_h, self.capacitance_f))

    def as_dict(self) -> dict[str, float | None]:
        """JSON-able values and standard errors."""
        out: dict[str, float | None] = {name: getattr(self, name) for name in _NAMES}
        out.update({f"{name}_stderr": _finite(self.stderr[name]) for name in _NAMES})
        out.update(rms_ppm=self.rms_ppm, resonance_hz=self.resonance_hz, t_coil_c=_finite(self.t_coil_c))
        return out


def fit_parallel_rlc(freq_hz: np.ndarray, ls_h: np.ndarray, rs_ohm: np.ndarray) -> RlcFit:
    """Fit L, C, R_p and R_s to series readings over frequency (at least four frequencies)."""
    freq, ls, rs = (np.asarray(a, float) for a in (freq_hz, ls_h, rs_ohm))
    if len(np.unique(freq)) < 4:
        raise ValueError("a parallel RLC fit needs readings at four or more frequencies")
    omega = 2 * np.pi * freq
    z = rs + 1j * omega * ls
    start = _start(freq, ls, rs, z)

    def values(theta: np.ndarray) -> np.ndarray:
        return np.array([start[0] * np.exp(theta[0]), start[1] * np.exp(theta[1]),
                         start[2] * np.exp(theta[2]), start[3] * (1 + theta[3])])

    def residuals(theta: np.ndarray) -> np.ndarray:
        v = values(theta)
        diff = (parallel_rlc_impedance(omega, v[0], v[1], v[2], v[3]) - z) / np.abs(z)
        return np.concatenate([diff.real, diff.imag]) * 1e6

    result = least_squares(residuals, np.zeros(4), bounds=([-np.inf] * 3 + [-1.0], np.inf), method="trf",
                           x_scale=1.0, ftol=1e-12, xtol=1e-12, gtol=1e-12)
    v = values(result.x)
    dof = max(len(result.fun) - 4, 1)
    s2 = float(result.fun @ result.fun) / dof
    cov = s2 * np.linalg.pinv(result.jac.T @ result.jac)
    sd_theta = np.sqrt(np.clip(np.diag(cov), 0, None))
    sd = np.concatenate([v[:3] * sd_theta[:3], [start[3] * sd_theta[3]]])
    rms = float(np.sqrt(np.mean(result.fun**2)))
    inductance, capacitance, parallel_resistance, series_resistance = v.tolist()
    return RlcFit(inductance, capacitance, parallel_resistance, series_resistance,
                  stderr=dict(zip(_NAMES, sd.tolist(), strict=True)), rms_ppm=rms)


def fit_spectroscopy(data: Measurements) -> list[RlcFit]:
    """One parallel RLC fit per segment of a spectroscopy recording, tagged with its coil temperature."""
    fits = []
    for segment in np.unique(data.segment):
        part = data.select(data.segment == segment)
        fit = fit_parallel_rlc(part.freq_hz, part.ls_h, part.rs_ohm)
        fit.t_coil_c = float(np.mean(part.t_coil_c))
        fits.append(fit)
    return fits


def _start(freq: np.ndarray, ls: np.ndarray, rs: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Analytic start: 1/Ls = 1/L - w^2 C below resonance; R_p from the peak |Z|; R_s from low-f Rs."""
    order = np.argsort(freq)
    freq, ls, rs, z = freq[order], ls[order], rs[order], z[order]
    omega = 2 * np.pi * freq
    negative = np.flatnonzero(ls <= 0)
    f_res = freq[negative[0]] if len(negative) else np.inf
    below = (freq < 0.5 * f_res) & (ls > 0)
    if below.sum() < 2:
        below = ls > 0
    slope, intercept = np.polyfit(omega[below] ** 2, 1 / ls[below], 1)
    inductance = 1 / intercept if intercept > 0 else float(ls[below][0])
    capacitance = -slope if slope < 0 else 1e-12
    if np.isfinite(f_res):
        parallel = float(np.max(np.abs(z)))
    else:
        excess = rs[-1] - rs[0]
        parallel = (omega[-1] * inductance) ** 2 / excess if excess > 0 else 1e9
    series = max(float(rs[0]), 1e-3)
    return np.array([inductance, capacitance, parallel, series])


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None
