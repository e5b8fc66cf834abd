"""parasitic_capacitance: moisture in the former adds capacitance and loss; heating drives it out.

A porous, hygroscopic former holds moisture m (1 at the start of a recording, when it has sat in
the lab) of two kinds, as in the textbook picture of drying (constant-rate, then falling-rate period):
- free water (share 1 - b) dries out and does not come back: dm_f/dt = -r(T) m_f^n. Its order n
  spans drying at a constant pace (n = 0: linear in the drying dose until dry) to drying in
  proportion to what is left (n = 1). With the dose D = int r dt, m_f = (1 - (1 - n) D)^(1 / (1 - n)),
  or exp(-D) for n = 1.
- bound (sorbed) water (share b) relaxes toward the equilibrium moisture of the sorption isotherm:
  dm_b/dt = -r(T) (m_b - m_eq(T)). Warming the former at the room's absolute humidity lowers the
  relative humidity at its pores like 1 / p_sat(T) (Clausius-Clapeyron: p_sat e-folds every ~18 K
  near room temperature), so m_eq = exp(-(T - T_0) / s), T_0 the recording's first coil temperature;
  held warm, the former stops drying once at m_eq, and cooling lets it take moisture up again.
The drying rate r(T) = r_hot / (1 + exp(-(T - T_onset) / width)), T the coil thermocouple, is
exponential in T well below the onset (evaporation, Arrhenius-like) and with a small width a plain
threshold ("time spent hot" above T_onset). b = 0 is the simpler law with free water only: fits
solve it first, then free b and s with the rest at its solution (``Effect.simpler_form``).
The coil's parallel capacitance is C_p + dC m and its loss conductance 1/R_p + dG m (Table 2:
62.5 pF / 92 kOhm moist, 47.5 pF / 984 kOhm dry). Seen through L || C, the apparent L changes
like 1/(1 - w^2 L C): strongly at 15 kHz, hardly at 500 Hz, and with hysteresis on cooling.
Moisture also swells a porous former (hygral strain), and the winding on it with it: every length of the coil
scaled by s = 1 + e (m - 1), e the moist former's strain against dry (m = 1 at the start). As for a thermal
expansion (``former_expansion``), the coil's own inductance scales by s and the coupling is the cold coil's at the
distance (x - p1) / s; early drying shrinks the coil, which is the paper's "initial decrease" of L_coil at 500 Hz
(Sec. 4.2, Fig. 19), where the capacitance hardly shows. The same water swells the former and adds the
capacitance, so the strain is a share of it: e = k dC / C_ref (``moist_swelling`` k, C_ref the larger of the dry
C_p and 50 pF). Water in the pores raises the relative capacitance by ~16x its volume share (permittivity 80
against a dry ceramic's ~5) and strains a clay or gypsum by ~1-5 % of it, so k ~ 6e-4 to 3e-3: a strain with
hardly any capacitance (a gain that drifts in time, taken for a drying) is no swelling.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.special import expit

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import Effect, Inputs, register
from ecds_lab.model.library.history import relaxation, relaxation_derivatives
from ecds_lab.model.library.remembered import Remembered
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import InputTangents, Tangent, chained, plus, scaled

#: The parameters the moisture m(t) depends on.
_MOISTURE_PARAMETERS = ("drying_rate", "drying_onset", "drying_width", "drying_order", "bound_share", "sorption_width")


#: The moisture m(t) as the model's derivatives carry it: one entry, unfolded into its parameters at the end
#: (``Effect.latent_tangents``).
MOISTURE = "parasitic_capacitance.moisture"

#: A moisture falling by less than this over a campaign (as a share of the start's) shows no drying temperature.
FALL_SEEN = 1e-3


def _moisture_key(p: Mapping[str, float]) -> tuple[float, ...]:
    """The values of the parameters the moisture m(t) depends on."""
    return tuple(p[name] for name in _MOISTURE_PARAMETERS)


@register
class ParasiticCapacitance(Effect):
    name = "parasitic_capacitance"
    explains = ("moisture in the former changes the coil's parallel capacitance (and swells the winding) as heating "
                "dries it")
    #: Table 2: the moist former adds ~15 pF to the coil's 47.5 pF. Water fills only the pores of the former
    #: between the turns, so moisture adds at most about the dry inter-winding capacitance itself, which
    #: grows with the winding (a large coil's C_p is several times the paper's): up to the larger of 50 pF
    #: and the sensor's own C_p (set per sensor in ``__init__``). Water (relative permittivity ~80) in the
    #: pores can only add capacitance: a negative dC, capacitance that rises as the former dries, is no drying.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"moist_dC": (0.0, 50e-12)}
    #: The strain per relative capacitance the water adds, k (module docstring: ~6e-4 to 3e-3), with room for a
    #: field that sees the pores only in part (less capacitance for the same strain): up to 0.02. Water swells a
    #: former, never shrinks it: a negative k only as far as noise puts a null one (the fit's lower bound too: a
    #: negative strain follows the coupling as a thermal expansion does, where the bound water follows the
    #: temperature).
    PLAUSIBLE_SWELLING = (-5e-4, 0.02)
    key_parameters = ("moist_dC",)
    #: The swelling only shapes how a drying shows (through L and the coupling, beside the capacitance): held where
    #: the fit left it when the data determine it poorly, so it does not blur the capacitance's size.
    nuisance_parameters = ("moist_swelling",)
    reveal = ("hold the coil at two or three temperatures for an hour each at 15 kHz, then cool it: drying "
              "changes L early in each heating, stops once the former holds its equilibrium moisture, and "
              "leaves a hysteresis on cooling")
    reveal_needs: ClassVar[dict[str, float]] = {"hold_s": 3000.0, "coil_span_k": 30.0}
    alternative_starts = ({"drying_rate": 1e-4}, {"drying_rate": 1e-2},
                          *({"drying_order": 0.0, "drying_rate": 3e-4, "drying_onset": onset, "drying_width": 1.0}
                            for onset in (60.0, 90.0)),
                          # all moisture bound, desorbing with an activation energy of ~50 kJ/mol (rate
                          # e-folding every ~20 K) from a former a few mm thick (~1e-3/s at 100 C).
                          {"bound_share": 1.0, "drying_rate": 1e-2, "drying_onset": 150.0, "drying_width": 20.0})
    simpler_form: ClassVar[dict[str, float]] = {"bound_share": 0.0, "sorption_width": 18.0}
    #: Free water drying at one pace at every coil temperature (the onset on its lowest bound, a threshold): a course
    #: in time alone, as a bridge's drifting gain runs. Drying is driven by heat: the data must show it faster hot.
    in_time_alone: ClassVar[dict[str, float]] = {"drying_onset": 20.0, "drying_width": 0.2, "bound_share": 0.0}
    reveal_beside_drift = ("log the coil at room temperature for an hour before heating it and after it has cooled: "
                           "a drift in time goes on there, a drying does not")

    def __init__(self, sensor: SensorConfig) -> None:
        super().__init__(sensor)
        limit = max(50e-12, sensor.capacitance_f)
        self.plausible = {"moist_dC": (0.0, limit),  # type: ignore[misc]  # per sensor, not per class
                          "moist_swelling": self.PLAUSIBLE_SWELLING}
        self._dc_bound = max(1e-10, 2 * limit)
        self._c_ref = limit
        # worked out once for the value and the derivatives a solver asks for at the same parameters
        self._timeline: Remembered[_Timeline] = Remembered()
        self._moisture: Remembered[np.ndarray] = Remembered()
        self._moisture_tangent: Remembered[dict[str, np.ndarray]] = Remembered()
        self._bound_water: Remembered[np.ndarray] = Remembered()

    def parameters(self) -> list[Parameter]:
        return [
            Parameter("moist_dC", 1e-12, -self._dc_bound, self._dc_bound, "F",
                      "extra parallel capacitance of the moist former", 5e-12),
            Parameter("moist_dG", 1e-6, 0.0, 1e-4, "S", "extra loss conductance of the moist former", 3e-6),
            Parameter("drying_rate", 1.0 / 300, 1e-7, 1.0, "1/s", "drying rate of the hot former (r_hot)", 1e-3),
            Parameter("drying_onset", 100.0, 20.0, 250.0, "C", "temperature at which drying reaches half its rate",
                      10.0),
            Parameter("drying_width", 17.0, 0.2, 60.0, "K", "width of the drying onset (small: a threshold)", 5.0),
            Parameter("drying_order", 1.0, 0.0, 2.0, "1", "order n of dm/dt = -r m^n (0 linear, 1 exponential)", 0.2),
            Parameter("bound_share", 0.5, 0.0, 1.0, "1", "share b of the moisture bound by sorption (0: all free)",
                      0.2),
            Parameter("sorption_width", 18.0, 1.0, 100.0, "K",
                      "warming s that lowers the bound water's equilibrium e-fold (p_sat: ~18 K)", 5.0),
            Parameter("moist_swelling", 0.0, self.PLAUSIBLE_SWELLING[0], 0.05, "1",
                      "strain of the winding on the moist former per capacitance the moisture adds (of C_ref)",
                      5e-4),
        ]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        span = float(np.ptp(data.t_coil_c)) if len(data) else 0.0
        if span < 10.0:
            return {q.name: f"coil temperature span {span:.1f} K < 10 K" for q in self.parameters()}
        out: dict[str, str] = {}
        if float(data.freq_hz.max()) < 2000:
            out["moist_dG"] = "low frequencies only: the loss hardly changes L"
        if len(np.unique(data.freq_hz)) < 2:
            out["moist_swelling"] = ("one frequency: a strain changes L as the capacitance does in air and differs "
                                     "from it only through the coupling, as a thermal expansion does; at two "
                                     "frequencies the capacitance acts (f2/f1)^2 times more at the higher")
        return out

    def signature(self, data: Measurements, values: Mapping[str, float]) -> tuple[float, dict[str, float]]:
        """ln of the drying rate at the coil temperature where the fitted former did its drying
        (``drying_temperature``): drying is seen when the data tell how fast the former dries where it dries.
        Onset and rate alone may each be open (an Arrhenius-like rise far below the onset fixes only their
        combination; a former dry before the hottest hold leaves the rate there open); a course the data leave
        wholly open (a step at a cooling hysteresis, say) is not drying."""
        at = self.drying_temperature(data, values)
        width = values["drying_width"]
        u = (at - values["drying_onset"]) / width
        share = float(expit(u))
        ln_rate = math.log(values["drying_rate"]) + math.log(max(share, 1e-300))
        return ln_rate, {"drying_rate": 1.0 / values["drying_rate"], "drying_onset": -(1.0 - share) / width,
                         "drying_width": -(1.0 - share) * u / width}

    def drying_temperature(self, data: Measurements, values: Mapping[str, float]) -> float:
        """The coil temperature (C) at which the former's moisture fell, its fall along each recording weighting the
        temperature it fell at; the hottest reading's where it hardly falls."""
        hottest = float(np.max(data.t_coil_c))
        line = self._line(data)
        moisture = self.moisture(data, values)[line.order]
        fall = np.where(line.restart, 0.0, np.maximum(-np.diff(moisture), 0.0))
        if not fall.sum() > FALL_SEEN:
            return hottest
        return float(np.sum(fall * 0.5 * (line.temp_c[1:] + line.temp_c[:-1])) / fall.sum())

    def moisture(self, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        """m(t) per recording: the drying rate and the equilibrium at the mean temperature of each interval."""
        if len(data) == 0:
            return np.ones(0)
        key = _moisture_key(p)
        return self._moisture.get(data, key, lambda: self._moisture_along(data, p, key))

    def _moisture_along(self, data: Measurements, p: Mapping[str, float], key: tuple[float, ...]) -> np.ndarray:
        """``moisture``'s work."""
        line = self._line(data)
        mid = 0.5 * (line.temp_c[1:] + line.temp_c[:-1])
        rate = p["drying_rate"] * expit((mid - p["drying_onset"]) / p["drying_width"])
        step = rate * line.dt_s
        dose = np.concatenate([[0.0], np.cumsum(step)])
        moisture = _remaining(dose - dose[line.first], p["drying_order"])
        if p["bound_share"] > 0:
            # colder than at the start: more sorbed water, capped at e^3 (the pores fill up)
            equilibrium = np.exp(np.minimum(-(mid - line.start_c[1:]) / p["sorption_width"], 3.0))
            bound = self._bound(data, key, rate, equilibrium)
            moisture = (1.0 - p["bound_share"]) * moisture + p["bound_share"] * bound
        out = np.empty(len(data))
        out[line.order] = moisture
        return out

    def moisture_derivatives(self, data: Measurements, p: Mapping[str, float]) -> dict[str, np.ndarray]:
        """dm/d parameter per row for the six parameters of ``moisture`` (the same recurrences differentiated)."""
        if len(data) == 0:
            return {name: np.zeros(0) for name in _MOISTURE_PARAMETERS}
        key = _moisture_key(p)
        return self._moisture_tangent.get(data, key, lambda: self._moisture_derivatives_along(data, p, key))

    def _moisture_derivatives_along(self, data: Measurements, p: Mapping[str, float], key: tuple[float, ...]
                                    ) -> dict[str, np.ndarray]:
        """``moisture_derivatives``' work."""
        line = self._line(data)
        mid = 0.5 * (line.temp_c[1:] + line.temp_c[:-1])
        z = (mid - p["drying_onset"]) / p["drying_width"]
        sigma = expit(z)
        rate = p["drying_rate"] * sigma
        d_rate = {"drying_rate": sigma, "drying_onset": -p["drying_rate"] * sigma * (1 - sigma) / p["drying_width"],
                  "drying_width": -p["drying_rate"] * sigma * (1 - sigma) * z / p["drying_width"]}
        dose = np.concatenate([[0.0], np.cumsum(rate * line.dt_s)])
        dose = dose - dose[line.first]
        free, by_dose, by_order = _remaining_derivatives(dose, p["drying_order"])
        d_free = {}
        for name, values in d_rate.items():
            d_dose = np.concatenate([[0.0], np.cumsum(values * line.dt_s)])
            d_free[name] = by_dose * (d_dose - d_dose[line.first])
        d_free["drying_order"] = by_order
        relative = -(mid - line.start_c[1:]) / p["sorption_width"]
        equilibrium = np.exp(np.minimum(relative, 3.0))
        bound = self._bound(data, key, rate, equilibrium)
        share = p["bound_share"]
        d_bound: dict[str, np.ndarray] = {}
        if share != 0:  # with no bound water (the simpler law) its derivatives count nothing: not computed
            d_equilibrium = np.where(relative < 3.0, -equilibrium * relative / p["sorption_width"], 0.0)
            # the rate's three parameters move the rate, the sorption width the equilibrium: one row each
            along = [*d_rate, "sorption_width"]
            moves_rate, moves_target = np.zeros((len(along), len(mid))), np.zeros((len(along), len(mid)))
            moves_rate[:len(d_rate)] = list(d_rate.values())
            moves_target[-1] = d_equilibrium
            d_bound = dict(zip(along, relaxation_derivatives(line.time_s, rate, equilibrium, bound, moves_rate,
                                                             moves_target, line.restart), strict=True))
        in_line = {name: (1.0 - share) * d_free.get(name, 0.0) + share * d_bound.get(name, 0.0)
                   for name in _MOISTURE_PARAMETERS if name != "bound_share"}
        in_line["bound_share"] = bound - free
        out = {}
        for name, values in in_line.items():
            out[name] = np.empty(len(data))
            out[name][line.order] = values
        return out

    def _line(self, data: Measurements) -> _Timeline:
        """The readings in time order per recording (``_Timeline``), laid out once per campaign."""
        return self._timeline.get(data, None, lambda: _Timeline.of(data))

    def _bound(self, data: Measurements, key: tuple[float, ...], rate: np.ndarray, equilibrium: np.ndarray
               ) -> np.ndarray:
        """The bound water along the timeline (its relaxation toward ``equilibrium`` at ``rate``), for the moisture
        parameters ``key``: integrated once for the value and the derivatives a solver asks for at the same
        parameters."""
        line = self._line(data)
        return self._bound_water.get(data, key,
                                     lambda: relaxation(line.time_s, rate, equilibrium, 1.0, restart=line.restart))

    def latent_tangents(self, data: Measurements, p: Mapping[str, float]) -> dict[str, Tangent]:
        return {MOISTURE: self.moisture_derivatives(data, p)}

    def _with_moisture(self, value: np.ndarray, tangent: Tangent, size: str, data: Measurements,
                       p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        """value + p[size] m and its tangent: m for the size, p[size] for the moisture (``MOISTURE``)."""
        moisture = self.moisture(data, p)
        own = {size: moisture, MOISTURE: np.full(len(moisture), p[size])}
        return value + p[size] * moisture, plus(tangent, own)

    def d_coil_capacitance(self, c_f: np.ndarray, dc: Tangent, inputs: Inputs, d_inputs: InputTangents,
                           data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._with_moisture(c_f, dc, "moist_dC", data, p)

    def d_parallel_conductance(self, g_s: np.ndarray, dg: Tangent, inputs: Inputs, d_inputs: InputTangents,
                               data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._with_moisture(g_s, dg, "moist_dG", data, p)

    def strain(self, p: Mapping[str, float]) -> float:
        """e = k dC / C_ref: the moist former's strain of the winding against dry."""
        return p["moist_swelling"] * p["moist_dC"] / self._c_ref

    def _scale(self, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        """s = 1 + e (m - 1): the winding's size against its size on the moist former at the start."""
        return 1.0 + self.strain(p) * (self.moisture(data, p) - 1.0)

    def _scale_and_tangent(self, data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        """s (``_scale``) and ds per parameter: (m - 1) de for the swelling and the capacitance, e for the moisture
        (``MOISTURE``)."""
        strain, wetter = self.strain(p), self.moisture(data, p) - 1.0
        return 1.0 + strain * wetter, {"moist_swelling": wetter * p["moist_dC"] / self._c_ref,
                                       "moist_dC": wetter * p["moist_swelling"] / self._c_ref,
                                       MOISTURE: np.full(len(wetter), strain)}

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        return p["p1"] + (x_m - p["p1"]) / self._scale(data, p)

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        scale, d_scale = self._scale_and_tangent(data, p)
        finite = np.isfinite(x_m)
        offset = np.where(finite, x_m - p["p1"], 0.0)
        own = scaled(d_scale, -offset / scale**2)
        own = plus(own, {"p1": np.where(finite, 1.0 - 1.0 / scale, 0.0)})
        return p["p1"] + (x_m - p["p1"]) / scale, chained(dx, 1.0 / scale, own)

    def coil_inductance(self, l_h: np.ndarray, inputs: Inputs, data: Measurements,
                        p: Mapping[str, float]) -> np.ndarray:
        return l_h * self._scale(data, p)

    def d_coil_inductance(self, l_h: np.ndarray, dl: Tangent, inputs: Inputs, d_inputs: InputTangents,
                          data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        scale, d_scale = self._scale_and_tangent(data, p)
        return l_h * scale, chained(dl, scale, scaled(d_scale, l_h))

    def coil_capacitance(self, c_f: np.ndarray, inputs: Inputs, data: Measurements,
                         p: Mapping[str, float]) -> np.ndarray:
        return c_f + p["moist_dC"] * self.moisture(data, p)

    def parallel_conductance(self, g_s: np.ndarray, inputs: Inputs, data: Measurements,
                             p: Mapping[str, float]) -> np.ndarray:
        return g_s + p["moist_dG"] * self.moisture(data, p)


@dataclass(frozen=True)
class _Timeline:
    """The readings recording by recording in time order, as one line: ``order`` (rows), their time
    and coil temperature, ``first`` (each position's recording's first position), ``start_c`` (the
    temperature there), ``dt_s`` (0 across recordings) and ``restart`` (intervals into a new one)."""

    order: np.ndarray
    time_s: np.ndarray
    temp_c: np.ndarray
    first: np.ndarray
    start_c: np.ndarray
    dt_s: np.ndarray
    restart: np.ndarray

    @staticmethod
    def of(data: Measurements) -> _Timeline:
        segments = data.segment_rows
        order = np.concatenate(segments)
        lengths = [len(rows) for rows in segments]
        heads = np.cumsum([0, *lengths[:-1]]).astype(int)
        first = np.repeat(heads, lengths)
        time_s, temp_c = data.time_s[order], data.t_coil_c[order]
        restart = np.zeros(len(order) - 1, bool)
        restart[heads[1:] - 1] = True
        dt_s = np.where(restart, 0.0, np.maximum(np.diff(time_s), 0.0))
        return _Timeline(order, time_s, temp_c, first, temp_c[first], dt_s, restart)


def _remaining(dose: np.ndarray, order: float) -> np.ndarray:
    """Moisture left after a drying dose, starting from 1: the closed form of dm/dD = -m^order."""
    if abs(order - 1.0) < 1e-6:
        return np.exp(-dose)
    # order < 1: dry (0) once the dose reaches 1/(1 - order); order > 1: the base stays >= 1.
    return np.clip(1.0 - (1.0 - order) * dose, 0.0, None) ** (1.0 / (1.0 - order))


def _remaining_derivatives(dose: np.ndarray, order: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``_remaining`` m and its derivatives dm/d dose and dm/d order. With B = 1 - (1 - n) D and
    e = 1/(1 - n): m = B^e, dm/dD = -m/B, dm/dn = m (e^2 ln B + e D/B) (0 once dry); at n = 1,
    m = exp(-D), dm/dD = -m and dm/dn = m D^2/2 (the limit)."""
    if abs(order - 1.0) < 1e-6:
        m = np.exp(-dose)
        return m, -m, m * dose**2 / 2
    base = np.clip(1.0 - (1.0 - order) * dose, 0.0, None)
    exponent = 1.0 / (1.0 - order)
    m = base**exponent
    wet = base > 0
    safe = np.where(wet, base, 1.0)
    by_dose = np.where(wet, -m / safe, 0.0)
    by_order = np.where(wet, m * (exponent**2 * np.log(safe) + exponent * dose / safe), 0.0)
    return m, by_dose, by_order
