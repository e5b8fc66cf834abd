"""The paper's equivalent circuit model (ECM), Eq. (1)-(4), and the parallel C of the coil.

All functions are vectorised over numpy arrays and use SI units.
"""

from __future__ import annotations

import numpy as np


def eddy_factor(omega: np.ndarray, tau_t: np.ndarray | float) -> np.ndarray:
    """f_T = (w tau_T)^2 / (1 + (w tau_T)^2): how fully the target screens the field (Eq. 2)."""
    wt2 = (omega * tau_t) ** 2
    return wt2 / (1.0 + wt2)


def coil_inductance(l0: float, alpha: float, beta: float, delta_t: np.ndarray) -> np.ndarray:
    """Air-coil inductance vs coil temperature rise, Eq. (4): L0 (1 + a dT + b dT^2)."""
    return l0 * (1.0 + alpha * delta_t + beta * delta_t**2)


def ecds_inductance(l_coil: np.ndarray, k2: np.ndarray, omega: np.ndarray, tau_t: np.ndarray) -> np.ndarray:
    """L_ECDS = L_coil (1 - k^2 f_T), Eq. (2)."""
    return l_coil * (1.0 - k2 * eddy_factor(omega, tau_t))


def ecds_resistance(r_coil: np.ndarray, l_coil: np.ndarray, k2: np.ndarray, omega: np.ndarray,
                    tau_t: np.ndarray) -> np.ndarray:
    """R_ECDS = R_coil (1 + k^2 w^2 tau_T tau_coil / (1 + (w tau_T)^2)), Eq. (3), tau_coil = L/R."""
    return r_coil + k2 * omega**2 * tau_t * l_coil / (1.0 + (omega * tau_t) ** 2)


def with_parallel_elements(z_series: np.ndarray, omega: np.ndarray, capacitance: np.ndarray | float,
                           parallel_resistance: np.ndarray | float = np.inf) -> np.ndarray:
    """Impedance the bridge sees: the series branch in parallel with C_coil (and a loss R_p)."""
    return 1.0 / (1.0 / z_series + 1j * omega * capacitance + 1.0 / parallel_resistance)


def parallel_rlc_impedance(omega: np.ndarray, inductance: float, capacitance: float,
                           resistance: float, series_resistance: float = 0.0) -> np.ndarray:
    """(R_s + jwL) || C || R: the resonance model of Table 2 (R_s = 0 gives the plain parallel RLC)."""
    return with_parallel_elements(series_resistance + 1j * omega * inductance, omega, capacitance, resistance)


def self_resonance_hz(inductance: float, capacitance: float) -> float:
    """The parallel LC's resonance 1/(2 pi sqrt(L C)) (Hz); infinite without a capacitance."""
    return 1 / (2 * np.pi * np.sqrt(inductance * capacitance)) if capacitance > 0 else float("inf")
