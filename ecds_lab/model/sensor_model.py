"""The sensor model: predicted bridge readings from named parameters, baseline ECM plus effects.

Pipeline (see ``ecds_lab.model.effects`` for the hooks at each stage):
(1) effective inputs x_eff, winding and target temperature; (2) tau_T;
(3) baseline: L_coil = L0 (1 + a dT + b dT^2) (Eq. 4), k^ = p3 k((x - p1)/p2) + p4 (Eq. 5),
    L = L_coil (1 - k^2 f_T) (Eq. 2), R from Eq. (3) with the sensor's R0 and tempco;
(4) the coil's parallel C and loss conductance; (5) apparent Ls = Im(Z)/w of (R + jwL) || C || R_p.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model import ecm
from ecds_lab.model.baseline import baseline_parameters, baseline_unidentifiable
from ecds_lab.model.coupling import Coupling, image_method_coupling, table_coupling
from ecds_lab.model.effects import Effect, EffectRegistry, Inputs, make_effect
from ecds_lab.model.parameters import Parameter, check_unique

#: Half-step (m) of the central difference for dL/dx: small against the coil (~0.1 m), large
#: against rounding (L changes ~1e-7 relative over it).
SENSITIVITY_STEP_M = 1e-6


def sensor_coupling(sensor: SensorConfig) -> Coupling:
    """k(x) of a sensor: its coupling table if it names one, else the image method on its geometry."""
    return table_coupling(sensor.coupling_table) if sensor.coupling_table else image_method_coupling(sensor.coil)


class SensorModel:
    """Baseline ECM plus named effects; evaluates the bridge's apparent series L for measurements."""

    def __init__(self, sensor: SensorConfig | None = None, effects: Sequence[str | Effect] = (),
                 coupling: Coupling | None = None, registry: EffectRegistry | None = None) -> None:
        """``effects`` by name (looked up in ``registry``, default the library) or as Effect objects."""
        self.sensor = sensor or SensorConfig()
        self.coupling = coupling or sensor_coupling(self.sensor)
        self.effects = [make_effect(e, self.sensor, registry) if isinstance(e, str) else e for e in effects]
        names = [e.name for e in self.effects]
        if len(set(names)) != len(names):
            raise ValueError(f"effect listed twice: {names}")
        check_unique(self.parameters())

    @property
    def effect_names(self) -> list[str]:
        return [e.name for e in self.effects]

    def parameters(self) -> list[Parameter]:
        """Every parameter with its default start, bounds and unit: baseline first, then each effect's."""
        return baseline_parameters(self.sensor) + [p for e in self.effects for p in e.parameters()]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        """Parameters these data cannot determine (name -> reason), from the baseline and every effect."""
        out = baseline_unidentifiable(data)
        for effect in self.effects:
            for name in effect.identifies(data):
                out.pop(name, None)
        for effect in self.effects:
            out.update(effect.unidentifiable(data))
        return out

    def coupling_hat(self, x_m: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Calibrated coupling Eq. (5), k^ = p3 k((x - p1)/p2) + p4; zero for the coil in air."""
        x = np.asarray(x_m, float)
        finite = np.isfinite(x)
        scaled = np.where(finite, (x - p["p1"]) / p["p2"], np.inf)
        return np.where(finite, p["p3"] * self.coupling(scaled) + p["p4"], 0.0)

    def inputs(self, data: Measurements, p: Mapping[str, float], x_m: np.ndarray | None = None) -> Inputs:
        """Stage 1: effective distance and temperatures after every effect."""
        x = np.asarray(data.x_m if x_m is None else x_m, float)
        t_winding, t_target = data.t_coil_c, data.t_target_c
        for effect in self.effects:
            x = effect.effective_distance(x, data, p)
            t_winding = effect.winding_temperature(t_winding, data, p)
            t_target = effect.target_temperature(t_target, data, p)
        return Inputs(x, t_winding, t_target)

    def impedance(self, data: Measurements, p: Mapping[str, float], x_m: np.ndarray | None = None) -> np.ndarray:
        """Complex impedance at the bridge terminals (Ohm) for every row; ``x_m`` overrides the distance."""
        sensor, n = self.sensor, len(data)
        inputs = self.inputs(data, p, x_m)
        tau = np.full(n, p["tau_t"])
        for effect in self.effects:
            tau = effect.target_tau(tau, inputs, data, p)
        omega = 2 * np.pi * data.freq_hz
        d_coil = inputs.t_winding_c - sensor.reference_temperature_c
        l_coil = ecm.coil_inductance(p["L0"], p["alpha"], p["beta"], d_coil)
        k2 = self.coupling_hat(inputs.x_m, p) ** 2
        l_true = ecm.ecds_inductance(l_coil, k2, omega, tau)
        for effect in self.effects:
            l_true = effect.series_inductance(l_true, inputs, data, p)
        r_coil = sensor.resistance_ohm * (1 + sensor.resistance_tempco_per_k * d_coil)
        r_true = ecm.ecds_resistance(r_coil, l_coil, k2, omega, tau)
        capacitance = np.full(n, p["C_p"])
        conductance = np.full(n, 1.0 / p["R_p"])
        for effect in self.effects:
            capacitance = effect.coil_capacitance(capacitance, inputs, data, p)
            conductance = effect.parallel_conductance(conductance, inputs, data, p)
        return 1.0 / (1.0 / (r_true + 1j * omega * l_true) + 1j * omega * capacitance + conductance)

    def predict(self, data: Measurements, p: Mapping[str, float], x_m: np.ndarray | None = None) -> np.ndarray:
        """Apparent series inductance Ls = Im(Z)/w (H) the bridge reports for every row."""
        return self.impedance(data, p, x_m).imag / (2 * np.pi * data.freq_hz)

    def sensitivity(self, data: Measurements, p: Mapping[str, float], x_m: np.ndarray | None = None) -> np.ndarray:
        """dLs/dx (H/m) at every row (at ``x_m`` if given): the one central difference used everywhere.

        NaN for the coil in air (no distance to differentiate along).
        """
        x = np.asarray(data.x_m if x_m is None else x_m, float)
        step = SENSITIVITY_STEP_M
        with np.errstate(invalid="ignore"):
            slope = (self.predict(data, p, x + step) - self.predict(data, p, x - step)) / (2 * step)
        return np.where(np.isfinite(x), slope, np.nan)

    def relative_sensitivity(self, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        """d ln Ls / dx (1/m) at every row: what a distance error does to a reading, relative (NaN in air)."""
        with np.errstate(all="ignore"):
            return self.sensitivity(data, p) / self.predict(data, p)
