"""The baseline model's parameters (Eq. 2, 4, 5 and the coil's parallel C) and what data determine them."""

from __future__ import annotations

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.parameters import Parameter

#: Coil temperature span (K) below which alpha and beta of Eq. (4) are fixed at 0, and beta alone.
MIN_SPAN_ALPHA_K = 5.0
MIN_SPAN_BETA_K = 30.0

#: Calibration parameters of Eq. (5) in the order they are released as distinct positions allow.
#: One position is kept spare: an exactly determined fit through a few points chases their
#: noise and bends between them (n = 4 points fit p3, p1, p2; p4 stays 0).
CALIBRATION_ORDER = ("p3", "p1", "p2", "p4")


def baseline_parameters(sensor: SensorConfig) -> list[Parameter]:
    """L0, alpha, beta, tau_t, p1..p4, C_p (free by default) and R_p (fixed from the sensor)."""
    l0, tau = sensor.inductance_h, sensor.target_tau_s
    return [
        Parameter("L0", l0, 0.0, np.inf, "H", "air-coil inductance at the reference temperature, Eq. (4)",
                  1e-3 * l0),
        Parameter("alpha", 0.0, -1e-3, 1e-3, "1/K", "linear temperature coefficient of L_coil, Eq. (4)", 1e-5),
        Parameter("beta", 0.0, -1e-5, 1e-5, "1/K^2", "quadratic temperature coefficient of L_coil, Eq. (4)", 1e-8),
        Parameter("tau_t", tau, 1e-3 * tau, 1e3 * tau, "s", "target eddy-current time constant L_T/R_T, Eq. (2)",
                  0.1 * tau),
        Parameter("p1", 0.0, -0.05, 0.05, "m", "offset of the distance in the coupling, Eq. (5)", 1e-3),
        Parameter("p2", 1.0, 0.2, 5.0, "1", "scale of the distance in the coupling, Eq. (5)", 0.01),
        Parameter("p3", 1.0, 0.2, 5.0, "1", "gain of the coupling, Eq. (5)", 0.01),
        Parameter("p4", 0.0, -0.5, 0.5, "1", "offset of the coupling, Eq. (5)", 0.01),
        Parameter("C_p", sensor.capacitance_f, 0.0, 1e-8, "F", "coil's parallel (inter-winding) capacitance",
                  5e-12),
        Parameter("R_p", sensor.parallel_resistance_ohm, 0.0, np.inf, "Ohm", "former loss as a parallel R",
                  0.1 * sensor.parallel_resistance_ohm, fixed=True),
    ]


def baseline_unidentifiable(data: Measurements) -> dict[str, str]:
    """Baseline parameters these data cannot determine, with the reason (they stay at their start)."""
    fixed: dict[str, str] = {"R_p": "fixed from the sensor description"}
    finite = np.isfinite(data.x_m)
    span = float(np.ptp(data.t_coil_c)) if len(data) else 0.0
    if span < MIN_SPAN_ALPHA_K:
        fixed["alpha"] = f"coil temperature span {span:.1f} K < {MIN_SPAN_ALPHA_K:g} K"
    if span < MIN_SPAN_BETA_K:
        fixed["beta"] = f"coil temperature span {span:.1f} K < {MIN_SPAN_BETA_K:g} K"
    if len(np.unique(data.freq_hz)) < 2:
        fixed["C_p"] = "one frequency only: C_p is not separable from L0"
    if not finite.any():
        fixed["tau_t"] = "no data with the target present"
    elif len(np.unique(data.freq_hz[finite])) < 2:
        fixed["tau_t"] = "fewer than two frequencies with the target present: tau_t is not separable from p3"
    positions = len(np.unique(np.round(data.x_m[finite], 7)))
    air = bool((~finite).any())
    releasable = positions - (1 if air else 2)
    for i, name in enumerate(CALIBRATION_ORDER):
        if i >= releasable:
            fixed[name] = ("no data with the target present" if positions == 0 else
                           f"{positions} distinct positions{'' if air else ' and no coil-in-air data'}"
                           f" determine only {max(releasable, 0)} of p1..p4 with a position to spare")
    return fixed
