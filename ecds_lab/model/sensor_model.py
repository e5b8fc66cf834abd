"""The sensor model: predicted bridge readings from named parameters, baseline ECM plus effects.

Pipeline (see ``ecds_lab.model.effects`` for the hooks at each stage):
(1) effective inputs x_eff, winding and target temperature; (2) tau_T;
(3) baseline: L_coil = L0 (1 + a dT + b dT^2) (Eq. 4), k^ = p3 k((x - p1)/p2) + p4 (Eq. 5),
    L = L_coil (1 - k^2 f_T) (Eq. 2), R from Eq. (3) with the sensor's R0 and tempco;
(4) the coil's parallel C and loss conductance; (5) apparent Ls = Im(Z)/w of (R + jwL) || C || R_p.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model import ecm
from ecds_lab.model.baseline import baseline_parameters, baseline_unidentifiable
from ecds_lab.model.coupling import Coupling, image_method_coupling, table_coupling
from ecds_lab.model.effects import Effect, EffectRegistry, Inputs, make_effect
from ecds_lab.model.parameters import Parameter, check_unique
from ecds_lab.model.tangents import InputTangents, Tangent, add_to, plus, scaled

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

    def effect(self, name: str) -> Effect:
        """The model's effect named ``name``."""
        return next(e for e in self.effects if e.name == name)

    def parameters(self) -> list[Parameter]:
        """Every parameter with its default start, bounds and unit: baseline first, then each effect's (a shared
        parameter, ``Effect.shared_parameters``, once: as the first effect declaring it gives it)."""
        out = baseline_parameters(self.sensor)
        shared: set[str] = set()
        for effect in self.effects:
            out += [p for p in effect.parameters() if p.name not in shared]
            shared |= set(effect.shared_parameters)
        return out

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        """Parameters these data cannot determine (name -> reason), from the baseline and every effect; a shared
        parameter only where every effect declaring it says so."""
        out = baseline_unidentifiable(data)
        for effect in self.effects:
            for name in effect.identifies(data):
                out.pop(name, None)
        determined: set[str] = set()
        for effect in self.effects:
            fixed = effect.unidentifiable(data)
            out.update({k: v for k, v in fixed.items() if k not in determined})
            determined |= {p.name for p in effect.parameters() if p.name in effect.shared_parameters} - set(fixed)
        for name in determined:
            out.pop(name, None)
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
        for effect in self.effects:
            l_coil = effect.coil_inductance(l_coil, inputs, data, p)
        k2 = self.coupling_hat(inputs.x_m, p) ** 2
        for effect in self.effects:
            if effect.changes_coupling():
                k2 = effect.coupling_squared(k2, inputs, data, p, lambda x: self.coupling_hat(x, p))
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

    @property
    def has_derivatives(self) -> bool:
        """True when every effect gives its derivatives (``Effect.has_derivatives``): then
        ``prediction_and_jacobian`` is exact; otherwise fits take finite differences."""
        return all(effect.has_derivatives() for effect in self.effects)

    def coupling_hat_tangent(self, x_m: np.ndarray, dx: Tangent, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        """Eq. (5) and its tangent: d k^ = p3 k'(s) (dx - dp1 - s dp2) / p2 + k(s) dp3 + dp4, s = (x - p1)/p2;
        zero for the coil in air, and k' zero where k is held constant (below the table, beyond it)."""
        x = np.asarray(x_m, float)
        finite = np.isfinite(x)
        scaled_x = np.where(finite, (x - p["p1"]) / p["p2"], np.inf)
        k = self.coupling(scaled_x)
        inside = finite & (scaled_x >= self.coupling.x_m[0])
        slope = np.where(inside, p["p3"] * self.coupling.derivative(np.where(inside, scaled_x, 1.0)) / p["p2"], 0.0)
        with np.errstate(invalid="ignore"):
            tangent = {name: np.where(finite, slope * values, 0.0) for name, values in dx.items()}
        own = {"p1": -slope, "p2": -slope * np.where(finite, scaled_x, 0.0), "p3": np.where(finite, k, 0.0),
               "p4": finite.astype(float)}
        return np.where(finite, p["p3"] * k + p["p4"], 0.0), plus(tangent, own)

    def prediction_and_jacobian(self, data: Measurements, p: Mapping[str, float],
                                names: Collection[str] | None = None) -> tuple[np.ndarray, Tangent]:
        """Ls (as ``predict``) and its exact derivative with respect to the parameters ``names`` (default: all):
        name -> dLs/dp per row (absent: zero).

        The same pipeline as ``impedance``, each quantity carried with its tangent (forward mode); every
        effect's ``d_<hook>`` gives its part. Needs ``has_derivatives``.
        """
        asked = set(p) if names is None else set(names)
        latents: dict[str, Tangent] = {}
        for effect in self.effects:
            latents.update(effect.latent_tangents(data, p))
        wanted = asked | set(latents)  # an effect's latent quantities are carried as one entry each, unfolded below

        def only(tangent: Tangent) -> Tangent:
            return {name: values for name, values in tangent.items() if name in wanted}

        sensor, n = self.sensor, len(data)
        x, t_winding, t_target = np.asarray(data.x_m, float), data.t_coil_c, data.t_target_c
        dx: Tangent = {}
        dtw: Tangent = {}
        dtt: Tangent = {}
        for effect in self.effects:
            x, dx = effect.d_effective_distance(x, dx, data, p)
            t_winding, dtw = effect.d_winding_temperature(t_winding, dtw, data, p)
            t_target, dtt = effect.d_target_temperature(t_target, dtt, data, p)
            dx, dtw, dtt = only(dx), only(dtw), only(dtt)
        inputs, d_inputs = Inputs(x, t_winding, t_target), InputTangents(dx, dtw, dtt)
        tau = np.full(n, p["tau_t"])
        dtau: Tangent = only({"tau_t": np.ones(n)})
        for effect in self.effects:
            tau, dtau = effect.d_target_tau(tau, dtau, inputs, d_inputs, data, p)
            dtau = only(dtau)
        omega = 2 * np.pi * data.freq_hz
        d_coil = inputs.t_winding_c - sensor.reference_temperature_c
        shape = 1.0 + p["alpha"] * d_coil + p["beta"] * d_coil**2
        l_coil = p["L0"] * shape
        own_l_coil = only({"L0": shape, "alpha": p["L0"] * d_coil, "beta": p["L0"] * d_coil**2})
        l_coil_by_t = p["L0"] * (p["alpha"] + 2 * p["beta"] * d_coil)
        # L_coil's tangent itself, for the effects that change it or L_true (a few parameters: Eq. (4)'s, the
        # winding's temperature's and the effects' own); else its parts enter the Jacobian folded, below
        coil_hooked = any(type(effect).coil_inductance is not Effect.coil_inductance for effect in self.effects)
        hooked = any(type(effect).series_inductance is not Effect.series_inductance for effect in self.effects)
        dl_coil: Tangent = plus(scaled(dtw, l_coil_by_t), own_l_coil) if coil_hooked or hooked else {}
        if coil_hooked:
            for effect in self.effects:
                l_coil, dl_coil = effect.d_coil_inductance(l_coil, dl_coil, inputs, d_inputs, data, p)
                dl_coil = only(dl_coil)
        k_hat, dk_hat = self.coupling_hat_tangent(inputs.x_m, dx, p)
        k2 = k_hat**2
        # the coupling's tangent: k^'s (2 k^ then enters its factors), or k^2's itself where an effect reshapes k^2
        d_coupling = only(dk_hat)
        reshaping = [effect for effect in self.effects if effect.changes_coupling()]
        reshaped = bool(reshaping)
        if reshaped:
            d_coupling = scaled(d_coupling, 2 * k_hat)
            for effect in reshaping:
                k2, d_coupling = effect.d_coupling_squared(k2, d_coupling, inputs, d_inputs, data, p,
                                                           lambda x, d: self.coupling_hat_tangent(x, d, p))
                d_coupling = only(d_coupling)
        wt2 = (omega * tau) ** 2
        f_t = wt2 / (1.0 + wt2)
        f_t_by_tau = 2 * omega**2 * tau / (1.0 + wt2) ** 2
        l_true = l_coil * (1.0 - k2 * f_t)
        # the factors of dL_true on dL_coil, dk^ and dtau (Eq. 2)
        l_by_l_coil, l_by_k, l_by_tau = 1.0 - k2 * f_t, -l_coil * f_t * 2 * k_hat, -l_coil * k2 * f_t_by_tau
        if reshaped:
            l_by_k = -l_coil * f_t
        if hooked:  # L_true's tangent itself, for the effects that change it
            dl_true = plus(scaled(dl_coil, l_by_l_coil), scaled(d_coupling, l_by_k), scaled(dtau, l_by_tau))
            for effect in self.effects:
                l_true, dl_true = effect.d_series_inductance(l_true, dl_true, inputs, d_inputs, data, p)
                dl_true = only(dl_true)
        r_coil = sensor.resistance_ohm * (1 + sensor.resistance_tempco_per_k * d_coil)
        g = omega**2 * tau / (1.0 + wt2)
        g_by_tau = omega**2 * (1.0 - wt2) / (1.0 + wt2) ** 2
        r_true = r_coil + k2 * g * l_coil
        capacitance = np.full(n, p["C_p"])
        dcap: Tangent = only({"C_p": np.ones(n)})
        conductance = np.full(n, 1.0 / p["R_p"])
        dcond: Tangent = only({"R_p": np.full(n, -1.0 / p["R_p"] ** 2)})
        for effect in self.effects:
            capacitance, dcap = effect.d_coil_capacitance(capacitance, dcap, inputs, d_inputs, data, p)
            conductance, dcond = effect.d_parallel_conductance(conductance, dcond, inputs, d_inputs, data, p)
            dcap, dcond = only(dcap), only(dcond)
        series = r_true + 1j * omega * l_true
        z = 1.0 / (1.0 / series + 1j * omega * capacitance + conductance)
        # dZ = -Z^2 dY, dY = -(dR + j w dL) / Zs^2 + j w dC + dG, and dLs = Im(dZ) / w, in real arithmetic:
        # dLs = (Im(A) dR + Re(A) w dL - Re(Z^2) w dC - Im(Z^2) dG) / w with A = Z^2 / Zs^2. Each tangent enters
        # once, with its factors folded (reverse order over these pointwise steps): R_true = R_coil + k^2 g L_coil.
        z2 = z**2
        a = z2 / series**2
        by_r, by_l = a.imag / omega, a.real
        jacobian: Tangent = {}
        by_l_coil = by_r * k2 * g
        by_k = by_r * g * l_coil * 2 * k_hat if not reshaped else by_r * g * l_coil
        by_tau = by_r * k2 * l_coil * g_by_tau
        if hooked:
            add_to(jacobian, dl_true, by_l)
        else:
            by_l_coil = by_l_coil + by_l * l_by_l_coil
            by_k = by_k + by_l * l_by_k
            by_tau = by_tau + by_l * l_by_tau
        by_t_wire = by_r * sensor.resistance_ohm * sensor.resistance_tempco_per_k
        if coil_hooked:
            add_to(jacobian, dl_coil, by_l_coil)
            add_to(jacobian, dtw, by_t_wire)
        else:
            add_to(jacobian, own_l_coil, by_l_coil)
            add_to(jacobian, dtw, by_l_coil * l_coil_by_t + by_t_wire)
        add_to(jacobian, d_coupling, by_k)
        add_to(jacobian, dtau, by_tau)
        add_to(jacobian, dcap, -z2.real)
        add_to(jacobian, dcond, -z2.imag / omega)
        for latent, by_parameter in latents.items():
            through = jacobian.pop(latent, None)
            if through is not None:
                add_to(jacobian, {name: d for name, d in by_parameter.items() if name in asked}, through)
        return z.imag / omega, jacobian

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
