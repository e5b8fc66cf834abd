"""target_tau_temperature: the target's conductivity falls as it heats; the eddy currents follow.

One resistivity ratio r(T) = rho(T)/rho_0 = tau_0/tau_T(T) acts in two ways:

1. The equivalent circuit's time constant tau_T = L_T/R_T falls with the conductivity (copper:
   ~0.39 %/K): ln tau = ln tau0 + a dT + b dT^2 (dT = target temperature rise), which covers a
   linear fall of conductivity and a linear rise of resistivity alike over 100 K.
2. The skin-depth recession. A plate thick against the skin depth delta = sqrt(2 rho/(omega mu_0))
   has the surface impedance (1 + j)/(sigma delta): its reactive part is that of a perfect conductor
   whose surface lies delta/2 behind the face, so the coil senses the distance x + delta/2. As the
   resistivity rises delta grows as sqrt(rho) and the effective distance with it, alike at every
   distance (copper at 15 kHz: ~0.5 um/K). A plate of thickness d (a slab over air, textbook
   transmission-line form, field scale >> delta) recedes by Re{coth(gamma d)/gamma},
   gamma = (1 + j)/delta: delta/2 when d >> delta, and its change with rho fades as d falls below
   ~2 delta (copper at 500 Hz: delta = 2.9 mm, where a plate of a few mm recedes less than
   delta/2 would say). The equivalent circuit cannot express the recession once omega tau_T >> 1
   (its response to tau_T fades as 1/(omega tau_T)^2); without it a conductivity change at 15 kHz
   looks like a distance shift (bending). Bending shifts the distance alike at every frequency, the
   recession as f^-1/2 (thick plate): two frequencies tell them apart, one cannot.

Both describe the same eddy currents, so they share out the action by the plate's thickness in
skin depths: the recession carries w = 1 - exp(-2 d/delta) (the share of the field the plate
absorbs: a thick plate screens through its skin), the tau_T change the rest 1 - w (a sheet thin
against delta acts through its sheet conductance sigma d, i.e. through tau_T; a fitted thickness
near zero gives back the equivalent circuit's effect alone). Without this a thick plate's
conductivity change would be counted twice at 500 Hz.

The recession's size comes from the sensor's target material, not from a fitted size s_ref: the
textbook resistivity of copper (1.68e-8 Ohm m at 20 C, mu_r = 1, delta/2 = 0.27 mm at 15 kHz)
fixes delta at every frequency, and the one thing the analysis does not know, the plate's
thickness, is fitted unless the sensor description gives it (``target_thickness_m``) (a size, a
thickness and a tempco cannot all be told from two frequencies;
with the size known, the tempco and the thickness can). With two frequencies the thickness shows
in how the action changes with frequency; with one, only in its shape in x (a shift for a thick
plate, a change of screening for a thin one), so it is a nuisance parameter: where the data
determine it poorly the diagnosis holds it where the fit left it. It starts thin (0.1 mm, both
shares move with it there), with a sheet-like and a thick start as alternatives. With a bending
as well, two frequencies give two temperature responses for three unknowns (tempco, thickness,
bending): the data then cannot size the bending apart from the thickness.

A magnetic target (steel) screens from its complex depth D = mu_r delta/2 instead (``magnetic_depth``,
docs/physics.md "A magnetic plate"), and D ~ sqrt(mu_r/sigma): as the conductivity falls (and steel's mu_r rises)
with temperature, D(T) = D exp(-(a dT + b dT^2)/2), a change of set-back D(f) (D(T)/D - 1) and of the depth's
curvature of k^2. That is the effect there; the ECM's tau_T, which describes no loop of a magnetic plate, is left
alone. D is ``magnetic_depth``'s parameter (shared): the change alone trades D against a, so without that effect
in the model D is held at the textbook steel's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import NON_MAGNETIC_RESISTIVITY_OHM_M, SensorConfig
from ecds_lab.model.effects import GIVEN_BY_SENSOR, Effect, Inputs, register
from ecds_lab.model.library.magnetic_depth import (
    curvature,
    curvature_and_tangent,
    deepened,
    depth_parameter,
    is_magnetic,
)
from ecds_lab.model.library.magnetic_depth import per_frequency as depth_per_frequency
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import InputTangents, Tangent, plus, scaled
from ecds_lab.model.temperature_levels import curvature_unseen

#: Vacuum permeability (H/m).
MU_0 = 4e-7 * math.pi
#: ``plate_recession``'s scale of the set-back over the material's: where that effect is in the model, the change
#: of set-back with the conductivity is the same plate's and scales with it.
RECESSION_SCALE = "recession_scale"
#: Above this |gamma d| coth(gamma d) is 1 to double precision (and tanh would overflow beyond).
THICK_GAMMA_D = 20.0


def skin_depth_m(resistivity_ohm_m: np.ndarray | float, freq_hz: np.ndarray | float) -> np.ndarray:
    """delta = sqrt(2 rho / (omega mu_0)) of a non-magnetic conductor (m)."""
    return np.sqrt(2.0 * np.asarray(resistivity_ohm_m) / (2.0 * np.pi * np.asarray(freq_hz) * MU_0))


def recession_m(delta_m: np.ndarray, thickness_m: float) -> np.ndarray:
    """Depth behind the face of the perfect conductor that screens like the plate: Re{coth(gamma d)/gamma},
    gamma = (1 + j)/delta (delta/2 for d >> delta)."""
    gamma = (1 + 1j) / delta_m
    return (1.0 / (np.tanh(_screening_argument(gamma, thickness_m)) * gamma)).real


def _screening_argument(gamma: np.ndarray, thickness_m: float) -> np.ndarray:
    """gamma d, with |gamma d| held at THICK_GAMMA_D beyond it (coth is 1 there to double precision)."""
    return np.minimum(np.abs(gamma) * thickness_m, THICK_GAMMA_D) * (1 + 1j) / math.sqrt(2.0)


def recession_and_derivatives_m(delta_m: np.ndarray, thickness_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``recession_m``, d recession / d delta and d recession / d thickness from one complex tanh (a Jacobian needs
    all three): with ``recession_m`` = Re{coth(u) delta/(1 + j)}, u = (1 + j) d/delta, d/dd = Re{-csch^2 u} and
    d/d delta = Re{coth(u)/(1 + j) + csch^2(u) d/delta}; beyond THICK_GAMMA_D, where coth is held at 1, only the
    first term of d/d delta remains."""
    q = 1 + 1j
    gamma = q / delta_m
    tanh = np.tanh(_screening_argument(gamma, thickness_m))
    thick = np.abs(gamma) * thickness_m >= THICK_GAMMA_D
    coth = 1.0 / tanh
    csch2 = np.where(thick, 0.0, coth**2 - 1.0)
    return (1.0 / (tanh * gamma)).real, (coth / q + csch2 * thickness_m / delta_m).real, (-csch2).real


def per_frequency(values_of: Callable[[np.ndarray], tuple[np.ndarray, ...]], delta_m: np.ndarray
                  ) -> tuple[np.ndarray, ...]:
    """``values_of(delta)`` for a skin depth that depends on the frequency only: computed once per frequency
    (a campaign has two), then spread over the rows."""
    unique, rows = np.unique(delta_m, return_inverse=True)
    return tuple(np.asarray(v)[rows] for v in values_of(unique))


@register
class TargetTauTemperature(Effect):
    name = "target_tau_temperature"
    explains = ("the target's conductivity changes with target temperature: its eddy-current time constant and "
                "the skin-depth recession of its effective surface follow")
    #: Conductivity of metals falls ~0.3-0.45 %/K; permeability changes of steel add to it: |a| <= 2 %/K.
    #: The curvature b: a pure metal's resistivity is linear in temperature above a third of its Debye temperature
    #: (copper 1.54 -> 2.23e-8 Ohm m from 0 to 100 C, its slope constant to ~2 %), so ln tau_T = -ln(1 + alpha dT)
    #: curves by +alpha^2/2: copper 7.6e-6/K^2, aluminium 9e-6/K^2. Steel's conductivity falling 5 -> 3 MS/m while
    #: its mu_r doubles over ~100 K (docs/physics.md), each linear, gives (alpha^2 - beta^2)/2 ~ -3e-5/K^2, and
    #: -5e-5 if the permeability's rise alone bends it. +-5e-5: ln tau_T off its tangent by at most 0.5 at 100 K.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"tau_tempco": (-0.02, 0.02), "tau_tempco2": (-5e-5, 5e-5)}
    key_parameters = ("tau_tempco",)
    #: ln tau_T moves by a dT + b dT^2: with sweeps at two temperatures (a curvature seen only on a heating log at
    #: one position) a and b trade along a + b dT_hot, each undetermined while the change they make is not.
    size_parameters = ("tau_tempco", "tau_tempco2")
    #: One frequency shows the thickness only through the shape in x of the change (shift or screening).
    nuisance_parameters = ("plate_thickness",)
    #: One plate: ``plate_recession``'s thickness when both are in the model.
    shared_parameters = ("plate_thickness",)
    #: The thickness is the one valley-prone parameter: the 500 Hz share of the recession rises to a
    #: flat maximum near 3 delta(500 Hz), so sheet-like and thick starts are tried as well.
    THICKNESS_STARTS: ClassVar[tuple[dict[str, float], ...]] = ({"plate_thickness": 1e-5},
                                                                {"plate_thickness": 8e-3})
    reveal = ("measure at two frequencies with the target hot (500 Hz and 15 kHz; on steel two at which its screening "
              "depth's law holds, e.g. 15 and 50 kHz): a conductivity change alters the eddy-current screening at "
              "both in a way a bending cannot (the skin depth scales as f^-1/2)")
    reveal_needs: ClassVar[dict[str, float]] = {"frequencies_target_hot": 2}

    def __init__(self, sensor: SensorConfig) -> None:
        super().__init__(sensor)
        if self.resistivity_ohm_m is not None and sensor.target_thickness_m is None:  # a thickness to search for
            self.alternative_starts = self.THICKNESS_STARTS  # type: ignore[misc]  # per sensor, not per class
        if is_magnetic(sensor):  # its depth, ``magnetic_depth``'s where both are in the model
            self.shared_parameters = ("magnetic_depth",)  # type: ignore[misc]

    @property
    def resistivity_ohm_m(self) -> float | None:
        """The target's resistivity at 20 C if it is non-magnetic (its skin recession is modelled), else None."""
        return NON_MAGNETIC_RESISTIVITY_OHM_M.get(self.sensor.target)

    def parameters(self) -> list[Parameter]:
        out = [
            Parameter("tau_tempco", 0.0, -0.03, 0.03, "1/K", "d ln(tau_T) / d(target temperature)", 1e-3),
            Parameter("tau_tempco2", 0.0, -1e-4, 1e-4, "1/K^2", "curvature of ln(tau_T) in target temperature",
                      1e-6),
        ]
        if self.resistivity_ohm_m is not None:  # thin: both shares (recession, tau_T change) move with it
            known = self.sensor.target_thickness_m
            out.append(Parameter("plate_thickness", known if known is not None else 0.1e-3, 1e-6, 50e-3, "m",
                                 "thickness of the target plate (sets how its skin recession changes with frequency)",
                                 1e-3))
        elif is_magnetic(self.sensor):
            out.append(depth_parameter(self.sensor))
        return out

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        """tau_T acts only with the target under the coil: readings in air (a hot target cooling while the coil
        is away) show nothing of it, so its span and curvature are judged on the readings with a distance."""
        present = data.t_target_c[np.isfinite(data.x_m)]
        span = float(np.ptp(present)) if len(present) else 0.0
        thickness = self.resistivity_ohm_m is not None
        fixed: dict[str, str] = {}
        if thickness and self.sensor.target_thickness_m is not None:
            fixed["plate_thickness"] = GIVEN_BY_SENSOR
        if is_magnetic(self.sensor):  # its change D (r - 1) trades D against the tempco; the curvature tells D
            fixed["magnetic_depth"] = "the textbook steel's unless magnetic_depth (its curvature) is in the model"
        if span < 5.0:
            fixed.update(tau_tempco=f"target temperature span {span:.1f} K < 5 K", tau_tempco2="as tau_tempco")
            if thickness:
                fixed["plate_thickness"] = "as tau_tempco"
            return fixed
        why = curvature_unseen(present)
        if why is not None:
            fixed["tau_tempco2"] = why
        return fixed

    @staticmethod
    def _log_tau_ratio(t_target_c: np.ndarray, reference_c: float, p: Mapping[str, float]) -> np.ndarray:
        d_t = t_target_c - reference_c
        return p["tau_tempco"] * d_t + p["tau_tempco2"] * d_t**2

    def _rho(self) -> float:
        """The non-magnetic target's resistivity at 20 C: the skin recession's paths, which a magnetic plate's
        hooks leave before they reach them."""
        rho = self.resistivity_ohm_m
        assert rho is not None  # a magnetic plate returned at its own branch
        return rho

    def _skin_share(self, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        """w = 1 - exp(-2 d/delta): the share of the conductivity's action that is the skin recession."""
        return -np.expm1(-2.0 * p["plate_thickness"] / skin_depth_m(self._rho(), data.freq_hz))

    def _depth_ratio(self, data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A magnetic plate: its depth D(f) at 20 C, D(T)/D(20 C) = exp(-a dT/2 - b dT^2/2) (D ~ sigma^-1/2, the
        conductivity ~ tau_T) and the target's rise dT."""
        d_t = self._rise(data.t_target_c)
        ratio = np.exp(-0.5 * self._log_tau_ratio(data.t_target_c, self.sensor.reference_temperature_c, p))
        return p["magnetic_depth"] * depth_per_frequency(data.freq_hz), ratio, d_t

    def changes_coupling(self) -> bool:
        return is_magnetic(self.sensor)

    def coupling_squared(self, k2: np.ndarray, inputs: Inputs, data: Measurements, p: Mapping[str, float],
                         coupling_hat: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """A magnetic plate's depth change: the curvature of its depth at D(T) in place of D(20 C)."""
        if not is_magnetic(self.sensor):
            return k2
        depth, ratio, _ = self._depth_ratio(data, p)
        return k2 - 0.5 * depth**2 * (ratio**2 - 1) * curvature(k2, inputs.x_m, coupling_hat)

    def d_coupling_squared(self, k2: np.ndarray, dk2: Tangent, inputs: Inputs, d_inputs: InputTangents,
                           data: Measurements, p: Mapping[str, float],
                           coupling_hat_tangent: Callable[[np.ndarray, Tangent], tuple[np.ndarray, Tangent]]
                           ) -> tuple[np.ndarray, Tangent]:
        if not is_magnetic(self.sensor):
            return k2, dk2
        depth, ratio, d_t = self._depth_ratio(data, p)
        per = depth_per_frequency(data.freq_hz)
        bent, d_bent = curvature_and_tangent(k2, dk2, inputs.x_m, d_inputs.x_m, coupling_hat_tangent)
        by_log_ratio = -0.5 * depth * ratio
        d_hot = {"tau_tempco": by_log_ratio * d_t, "tau_tempco2": by_log_ratio * d_t**2, "magnetic_depth": per * ratio}
        return deepened(k2, dk2, bent, d_bent, depth * ratio, depth, d_hot, {"magnetic_depth": per})

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        if is_magnetic(self.sensor):
            return self.d_effective_distance(x_m, {}, data, p)[0]
        rho = self._rho()
        log_ratio = self._log_tau_ratio(data.t_target_c, self.sensor.reference_temperature_c, p)
        delta = skin_depth_m(rho, data.freq_hz)  # rho(T)/rho_0 = tau_0/tau_T(T)
        (cold,) = per_frequency(lambda d: (recession_m(d, p["plate_thickness"]),), delta)
        change = recession_m(delta * np.exp(-0.5 * log_ratio), p["plate_thickness"]) - cold
        return x_m + self._skin_share(data, p) * p.get(RECESSION_SCALE, 1.0) * change

    def target_tau(self, tau_s: np.ndarray, inputs: Inputs, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        if is_magnetic(self.sensor):  # its depth carries the change (the ECM's tau_T of steel is no loop's)
            return tau_s
        log_ratio = self._log_tau_ratio(inputs.t_target_c, self.sensor.reference_temperature_c, p)
        return tau_s * np.exp(log_ratio * (1 - self._skin_share(data, p)))

    def _rise(self, t_c: np.ndarray) -> np.ndarray:
        return t_c - self.sensor.reference_temperature_c

    def _skin_share_thickness(self, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        """d w / d thickness: (2 / delta) exp(-2 d / delta)."""
        delta = skin_depth_m(self._rho(), data.freq_hz)
        return 2.0 / delta * np.exp(-2.0 * p["plate_thickness"] / delta)

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        if is_magnetic(self.sensor):  # the depth's set-back D(f) (D(T)/D(20 C) - 1)
            depth, ratio, d_t = self._depth_ratio(data, p)
            by_log_ratio = -0.5 * depth * ratio
            return x_m + depth * (ratio - 1), plus(dx, {
                "tau_tempco": by_log_ratio * d_t, "tau_tempco2": by_log_ratio * d_t**2,
                "magnetic_depth": depth_per_frequency(data.freq_hz) * (ratio - 1)})
        d_t = self._rise(data.t_target_c)
        log_ratio = self._log_tau_ratio(data.t_target_c, self.sensor.reference_temperature_c, p)
        delta = skin_depth_m(self._rho(), data.freq_hz)
        hot = delta * np.exp(-0.5 * log_ratio)
        thickness = p["plate_thickness"]
        hot_recession, hot_by_delta, hot_by_thickness = recession_and_derivatives_m(hot, thickness)
        cold, _, cold_by_thickness = per_frequency(lambda d: recession_and_derivatives_m(d, thickness), delta)
        scale = p.get(RECESSION_SCALE, 1.0)
        change = scale * (hot_recession - cold)
        share = self._skin_share(data, p)
        by_log_ratio = share * scale * hot_by_delta * hot * -0.5
        own = {"tau_tempco": by_log_ratio * d_t, "tau_tempco2": by_log_ratio * d_t**2,
               "plate_thickness": self._skin_share_thickness(data, p) * change
               + share * scale * (hot_by_thickness - cold_by_thickness)}
        if RECESSION_SCALE in p:
            own[RECESSION_SCALE] = share * (hot_recession - cold)
        return x_m + share * change, plus(dx, own)

    def d_target_tau(self, tau_s: np.ndarray, dtau: Tangent, inputs: Inputs, d_inputs: InputTangents,
                     data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        if is_magnetic(self.sensor):
            return tau_s, dtau
        d_t = self._rise(inputs.t_target_c)
        log_ratio = self._log_tau_ratio(inputs.t_target_c, self.sensor.reference_temperature_c, p)
        keep = 1 - self._skin_share(data, p)
        out = tau_s * np.exp(log_ratio * keep)
        own = {"tau_tempco": out * keep * d_t, "tau_tempco2": out * keep * d_t**2,
               "plate_thickness": -out * log_ratio * self._skin_share_thickness(data, p)}
        by_temperature = scaled(d_inputs.t_target_c, out * keep * (p["tau_tempco"] + 2 * p["tau_tempco2"] * d_t))
        return out, plus(scaled(dtau, out / tau_s), own, by_temperature)
