"""A heater plant identified from a small power pulse: a fit of two lags and a dead time, and the PI(D) gains it
proposes by Skogestad's SIMC rules (S. Skogestad, "Simple analytic
rules for model reduction and PID controller tuning", J. Process Control 13 (2003) 291-309: the half rule,
Eq. (34)-(35) for a PI controller, Eq. (36)-(38) for a PID on a plant of two lags).

The pulse: ``power_w`` from ``on_s`` to ``off_s``, the thermocouple recorded from before ``on_s`` (its drift
before the pulse is taken as linear and removed) until after ``off_s``. The response to it is the
difference of two step responses, fitted by least squares (scipy). Gain and time constant come from the rise
and the fall; a short record determines their ratio (the initial slope) best, which is also what the gains
depend on most for a lag-dominated plant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ecds_lab.config.station import LoopGains
from ecds_lab.errors import EcdsLabError


@dataclass(frozen=True)
class HeaterPlant:
    """A heater plant: steady rise per heater watt, its time constant, a second smaller lag (0: first order) and a
    dead time."""

    gain_k_per_w: float
    tau_s: float
    dead_time_s: float
    lag_s: float = 0.0

    def step_rise_k(self, t_s: np.ndarray) -> np.ndarray:
        """Rise after a 1 W step at t = 0 (K)."""
        late = np.asarray(t_s, float) - self.dead_time_s
        if self.lag_s <= 0.0:
            return self.gain_k_per_w * (1.0 - np.exp(-np.clip(late, 0.0, None) / self.tau_s))
        return self.gain_k_per_w * _two_lag_step(late, self.tau_s, self.lag_s)


def _baseline(times_s: np.ndarray, temps_c: np.ndarray, on_s: float) -> tuple[float, float]:
    """Level at ``on_s`` and drift (K/s) of the readings before the pulse (one reading: no drift)."""
    before = times_s <= on_s
    if before.sum() >= 3 and np.ptp(times_s[before]) > 0:
        slope, level = np.polyfit(times_s[before] - on_s, temps_c[before], 1)
        return float(level), float(slope)
    return float(temps_c[before][-1] if before.any() else temps_c[0]), 0.0


def _two_lag_step(t_s: np.ndarray, tau1_s: float, tau2_s: float) -> np.ndarray:
    """Unit step response of two first-order lags in series (tau2 < tau1), zero before t = 0."""
    t = np.clip(t_s, 0.0, None)
    return 1.0 - (tau1_s * np.exp(-t / tau1_s) - tau2_s * np.exp(-t / tau2_s)) / (tau1_s - tau2_s)


def fit_pulse(times_s: np.ndarray, temps_c: np.ndarray, *, on_s: float, off_s: float,
              power_w: float) -> HeaterPlant:
    """The plant of two lags and a dead time (a heater warming a body that warms the thermocouple: the shipped
    coil's box and former) whose response to the pulse best fits the readings; EcdsLabError if it did not heat."""
    times_s, temps_c = np.asarray(times_s, float), np.asarray(temps_c, float)
    level, drift = _baseline(times_s, temps_c, on_s)
    after = times_s > on_s
    t = times_s[after] - on_s
    rise = temps_c[after] - (level + drift * t)
    if t.size < 4 or not np.isfinite(rise).all() or rise.max() <= 0.0:
        raise EcdsLabError("heater identification: the thermocouple did not rise during the step "
                           "(heater not wired to this thermocouple, or the step too small)")
    length = off_s - on_s
    peak = float(rise.max())
    slope = max(float(np.max(np.gradient(rise, t))), peak / max(float(t[-1]), 1.0))

    def response(p: np.ndarray) -> np.ndarray:
        gain, tau1, ratio, lag = math.exp(p[0]), math.exp(p[1]), p[2], p[3]
        tau2 = ratio * tau1
        return power_w * gain * (_two_lag_step(t - lag, tau1, tau2) - _two_lag_step(t - lag - length, tau1, tau2))

    best = None
    for tau0 in (max(float(t[-1]), 60.0), 4.0 * max(float(t[-1]), 60.0)):
        for ratio in (0.01, 0.1, 0.3):
            for lag in (0.0, 0.2 * length):
                k0 = slope * tau0 / power_w
                start = np.array([math.log(max(k0, 1e-6)), math.log(tau0), ratio, lag])
                bounds = ([-20.0, math.log(1.0), 0.001, 0.0], [20.0, math.log(1e6), 0.9, float(t[-1])])
                fit = least_squares(lambda p: response(p) - rise, start, method="trf", bounds=bounds)
                if best is None or fit.cost < best.cost:
                    best = fit
    assert best is not None
    gain, tau1, ratio, lag = math.exp(best.x[0]), math.exp(best.x[1]), float(best.x[2]), float(best.x[3])
    return HeaterPlant(gain, tau1, lag, ratio * tau1)


def simc_gains(plant: HeaterPlant, *, period_s: float, max_power_w: float) -> LoopGains:
    """Gains for the plant by SIMC, with effective dead time theta = its dead time plus half the control period and
    closed-loop time constant tc = 2 theta (at least one period; SIMC's "tight" tc = theta overshot on the simulated
    coil): Kc = tau / (K (tc + theta)), Ti = min(tau, 4 (tc + theta)). A second lag longer than theta is cancelled by
    a derivative, Td = that lag (SIMC's PID, Eq. (36)-(38), converted from its series form to the loop's parallel
    one); a shorter one is folded into tau and theta by the half rule (PI). Kc is kept where one kelvin of error
    asks at most the heater's full power."""
    theta = plant.dead_time_s + period_s
    tau, td = plant.tau_s, 0.0
    if plant.lag_s > theta:
        td = plant.lag_s
    else:
        tau, theta = tau + 0.5 * plant.lag_s, theta + 0.5 * plant.lag_s
    tc = max(2.0 * theta, 3.0 * period_s)
    kc = tau / (plant.gain_k_per_w * (tc + theta))
    ti = min(tau, 4.0 * (tc + theta))
    kp, ti_parallel, td_parallel = kc * (1.0 + td / ti), ti + td, ti * td / (ti + td)
    return LoopGains(kp_w_per_k=min(kp, max_power_w, 1000.0), ti_s=min(max(ti_parallel, 1.0), 100_000.0),
                     td_s=min(td_parallel, 100_000.0))
