"""Model effects: named additions to the baseline ECM, and the one registry of them.

An effect is one small class: a ``name`` (DESIGN.md's effect names), its own
``parameters()``, optionally ``unidentifiable(data)``, and any of the stage hooks
below. ``SensorModel`` evaluates a fixed pipeline and calls every effect's hook at
each stage, in the order the effects were given; a hook returns the changed quantity.

Stages (all arrays have one entry per data row, SI units):

1. effective inputs: ``effective_distance(x_m, data: Measurements, p)``,
   ``winding_temperature(t_c, data: Measurements, p)``, ``target_temperature(t_c, data: Measurements, p)``
2. target time constant: ``target_tau(tau_s, inputs, data: Measurements, p)``
3. the coil's own inductance after Eq. (4), ``coil_inductance(l_h, inputs, data: Measurements, p)``: for what
   changes the winding itself (a moist former's swelling scales it; the eddy currents' share, R and L, follows);
   the calibrated coupling squared, ``coupling_squared(k2, inputs, data: Measurements, p, coupling_hat)``: for a
   target that does not screen like a perfect conductor seen at one distance (``coupling_hat(x_m)`` is Eq. (5) at
   any distances, e.g. near the effective one); then the baseline ECM, Eq. (2)-(4), then
   ``series_inductance(l_h, inputs, data: Measurements, p)``: L of the series branch, for anything else that
   couples to the coil (e.g. a metal object near the slide)
4. coil parasitics: ``coil_capacitance(c_f, inputs, data: Measurements, p)``,
   ``parallel_conductance(g_s, inputs, data: Measurements, p)``
5. the bridge's apparent series inductance (no hook)

``inputs`` carries the stage-1 results (``x_m``, ``t_winding_c``, ``t_target_c``),
so later hooks see e.g. the effective target temperature. ``p`` maps every parameter
name of the model to its value. History-dependent effects (moisture, thermal lag)
integrate along time within each ``data.segment``.

To add an effect to the library: subclass ``Effect`` (``@register`` checks it has a name) and list
it in ``ecds_lab.model.library.LIBRARY``. Which effects a fit or a diagnosis may use is an
``EffectRegistry`` object handed to it (``library()``: the library plus installed packages' effects),
not a module-level table: users add their own without editing ecds-lab (``ecds_lab.model.plugins``)
to a registry of their own, from a Python file (``--effects-from FILE.py``) or an installed package
(entry point group ``ecds_lab.effects``), and tests build registries without touching anyone else's.

What the diagnosis needs to weigh a claim, declared by each effect: ``plausible`` (parameter ->
(low, high) in SI: the physically possible size), ``key_parameters`` (those that must be clearly
determined for the effect to be named; default: all its parameters) and ``reveal`` (the
measurement that shows the effect best, suggested when the data cannot separate it from another).
Derivatives: for each hook it overrides, an effect provides ``d_<hook>``, which returns the hook's result
and its derivative with respect to every parameter (forward mode, ``ecds_lab.model.tangents``); fits then
use the exact Jacobian. An effect without them still works: its model's fits take finite differences.
Where many of its parameters act through one quantity of its own (a moist former's moisture m(t)), the tangents
may carry that quantity as one entry, unfolded at the end (``Effect.latent_tangents``).

An effect that extends a simpler law declares ``simpler_form`` (parameter -> value giving that law):
fits solve the simpler law first, then free those parameters from their own start values with the
rest at that solution, and keep the better: the richer law never ends worse than the simpler one.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import InputTangents, Tangent

log = logging.getLogger("ecds_lab.model")

#: Why an effect holds a parameter at the value the sensor description gives: known, not left open by the data.
GIVEN_BY_SENSOR = "given by the sensor description"
#: The effect names DESIGN.md fixes (the contract of ``--effects`` and of the diagnosis).
EFFECT_NAMES = ("target_tau_temperature", "tau_displacement", "target_bending",
                "parasitic_capacitance", "thermal_lag", "slide_backlash", "former_expansion")


@dataclass(frozen=True)
class Inputs:
    """Effective inputs of the ECM after stage 1: distance (m, inf in air) and temperatures (C)."""

    x_m: np.ndarray
    t_winding_c: np.ndarray
    t_target_c: np.ndarray


class Effect:
    """Base of every effect: no parameters, every hook the identity."""

    name: ClassVar[str] = ""
    #: Other start values worth a try where the fit can settle in a wrong valley (e.g. time constants).
    alternative_starts: ClassVar[tuple[dict[str, float], ...]] = ()
    #: One line saying what the effect explains (for diagnoses and reports).
    explains: ClassVar[str] = ""
    #: Physically possible range of parameters (SI, name -> (low, high)); a fit outside is not claimed.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {}
    #: Parameters that must be clearly determined (not at a bound, stderr well below the value) for
    #: the effect to be named; empty: every parameter of the effect.
    key_parameters: ClassVar[tuple[str, ...]] = ()
    #: Parameters that together make the effect's size (all zero: the effect is absent), tested jointly when no
    #: key parameter alone is clearly determined (a bending's linear and quadratic terms in temperature trade when
    #: the sweeps see two temperatures, while the shift they make together is known); empty: the key parameters.
    size_parameters: ClassVar[tuple[str, ...]] = ()
    #: The measurement that shows this effect best (suggested when the data cannot separate it).
    reveal: ClassVar[str] = ""
    #: What a campaign must hold for ``reveal``'s measurement (keys of ``analysis.diagnosis.advice.Design``:
    #: frequencies, frequencies_target_hot, directions, target_span_k, coil_span_k, hold_s; finest_step_mm
    #: at most). A campaign that holds it is not advised to measure it again.
    reveal_needs: ClassVar[dict[str, float]] = {}
    #: Secondary parameters that only shape the effect (e.g. a plate's thickness): where the data
    #: determine one poorly (standard error above its value) the diagnosis holds it where the fit left
    #: it, so it does not blur the key parameters' standard errors.
    nuisance_parameters: ClassVar[tuple[str, ...]] = ()
    #: Parameter values that reduce the effect to a simpler law it contains (name -> value). A fit
    #: neither fixing nor starting them solves the simpler law first, then frees them (the better kept).
    simpler_form: ClassVar[dict[str, float]] = {}
    #: Parameter values at which the effect does nothing, for an effect whose start values are the size the
    #: physics predicts (a plate's skin recession from its material), not zero. The testability check then also
    #: asks whether that predicted action, start against absent, is visible beyond a calibration: a signature
    #: mostly absorbed by one (a shift of the distance at one frequency) may leave far more than the noise.
    absent_form: ClassVar[dict[str, float]] = {}
    #: Parameter values at which the effect's course runs in time alone, whatever the temperatures (empty: it has
    #: no such form). The slow drift every instrument has (a bridge's gain creeping with the hours) is such a
    #: course; a claim must fit better than this form by the evidence a claim needs (``checks.check_in_time``).
    in_time_alone: ClassVar[dict[str, float]] = {}
    #: True for an effect whose signature a slow drift in time leaves as well between sweeps taken one after another
    #: (a backlash's difference between the directions): a claim must keep the evidence a claim needs beside a
    #: straight-line drift of every reading in time (``checks.check_beyond_drift``).
    drift_leaves_it: ClassVar[bool] = False
    #: The measurement that tells the effect from a slow drift in time, suggested when the data could not
    #: (``in_time_alone``, ``drift_leaves_it``).
    reveal_beside_drift: ClassVar[str] = ""
    #: Parameters that are one physical quantity with another effect's parameter of the same name (a plate's
    #: thickness: its skin recession and its conductivity change are one plate's); a model with both effects
    #: holds one, declared by the first, and fixes it only where every effect declaring it would.
    shared_parameters: ClassVar[tuple[str, ...]] = ()
    #: False for an effect a diagnosis tries only when named among its candidates (it would tie with a library
    #: effect wherever it acts, and the tie would stand where that effect was claimed before).
    tried_by_default: ClassVar[bool] = True
    #: Modules the effect's search hooks (``starts_from_residual``) import when first called rather than at the top of
    #: its module, which every command loads: a diagnosis imports them once before it forks its workers, each of which
    #: would otherwise import them anew (scipy.signal: 0.65 s CPU a worker, five times a 10^5-reading diagnosis, when
    #: the lead screw's periodogram used it).
    modules_for_search: ClassVar[tuple[str, ...]] = ()

    def __init__(self, sensor: SensorConfig) -> None:
        self.sensor = sensor

    def parameters(self) -> list[Parameter]:
        """The effect's own parameters with starting values, bounds and units."""
        return []

    def key_names(self) -> tuple[str, ...]:
        """The parameters that must be clearly determined for it to be named: ``key_parameters``, or all its own."""
        return self.key_parameters or tuple(p.name for p in self.parameters())

    def size_names(self) -> tuple[str, ...]:
        """The parameters that together make its size: ``size_parameters``, or the key ones (``key_names``)."""
        return self.size_parameters or self.key_names()

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        """Parameters these data cannot determine (name -> reason); they are fixed at their start."""
        return {}

    def signature(self, data: Measurements, values: Mapping[str, float]) -> tuple[float, dict[str, float]] | None:
        """ln of the quantity that shows the effect's own course on ``data`` (a drying's rate where the former
        dried) and its derivatives by parameter, or None where the key parameters say it all. A claim needs
        it determined to better than its own value (standard error of the ln below 1): else the data show only
        that the effect's terms help, in whatever course its other parameters can bend to."""
        return None

    def starts_from_residual(self, data: Measurements, shift_m: np.ndarray,
                             weights: np.ndarray) -> tuple[dict[str, float], ...]:
        """Starts read off the current model's residual as a distance error (``shift_m``, m per reading,
        NaN where undefined; ``weights`` 1/variance of each, in 1/m^2), best first: the first is the fit's
        start, the rest join the alternatives (e.g. a screw's lead from a periodogram). None by default."""
        return ()

    @classmethod
    def applies_to(cls, sensor: SensorConfig) -> bool:
        """Whether the effect can act on this sensor at all (a magnetic plate's screening depth cannot on a copper
        one): a diagnosis tries by default only the effects that can."""
        return True

    def changes_coupling(self) -> bool:
        """Whether ``coupling_squared`` acts for this sensor (an effect may reshape k^2 on a magnetic plate only); the
        model carries k^2's own tangent only where one does."""
        return type(self).coupling_squared is not Effect.coupling_squared

    def held_out_of_reach(self, training: Measurements) -> dict[str, float]:
        """Parameters a held-out fold's training readings leave free, with the value its fit holds them at
        (``analysis.diagnosis.held_out``): a parameter that only readings near it determine (a spline's knot), when
        the fold holds all of those out. Default: none."""
        return {}

    def latent_tangents(self, data: Measurements, p: Mapping[str, float]) -> dict[str, Tangent]:
        """Quantities of the effect that many of its parameters act through (a moist former's moisture m(t)), each
        with its derivative by parameter: name -> parameter -> d quantity / d parameter per row. Its derivative hooks
        then carry one tangent entry for such a quantity instead of one per parameter, and the model's Jacobian
        unfolds it at the end (``SensorModel.prediction_and_jacobian``): the same derivatives, fewer rows carried
        through every stage. Names must not be parameter names. Default: none."""
        return {}

    def identifies(self, data: Measurements) -> set[str]:
        """Baseline parameters this effect makes determinable in these data although the baseline
        alone would not (e.g. tau_T at one frequency once it changes with target temperature)."""
        return set()

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        return x_m

    def winding_temperature(self, t_c: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        return t_c

    def target_temperature(self, t_c: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        return t_c

    def target_tau(self, tau_s: np.ndarray, inputs: Inputs, data: Measurements,
                   p: Mapping[str, float]) -> np.ndarray:
        return tau_s

    def coupling_squared(self, k2: np.ndarray, inputs: Inputs, data: Measurements, p: Mapping[str, float],
                         coupling_hat: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        return k2

    def coil_inductance(self, l_h: np.ndarray, inputs: Inputs, data: Measurements,
                        p: Mapping[str, float]) -> np.ndarray:
        return l_h

    def series_inductance(self, l_h: np.ndarray, inputs: Inputs, data: Measurements,
                          p: Mapping[str, float]) -> np.ndarray:
        return l_h

    def coil_capacitance(self, c_f: np.ndarray, inputs: Inputs, data: Measurements,
                         p: Mapping[str, float]) -> np.ndarray:
        return c_f

    def parallel_conductance(self, g_s: np.ndarray, inputs: Inputs, data: Measurements,
                             p: Mapping[str, float]) -> np.ndarray:
        return g_s

    # -- derivatives (forward mode, ``ecds_lab.model.tangents``) -----------------------------
    # Each ``d_<hook>`` returns what ``<hook>`` returns and its tangent: given the tangent of the quantity
    # it changes (and for stages 2-4 those of ``inputs``), the derivative of its result with respect to every
    # parameter (the chain rule through the quantity, plus its own partial derivatives). The base versions
    # are the identity, right for a hook the effect does not override; an effect that overrides a hook
    # without its ``d_`` version has no derivatives, and its model's fits fall back to finite differences.

    @classmethod
    def has_derivatives(cls) -> bool:
        """True when every hook the effect overrides has its derivative hook (``d_<hook>``) too."""
        return all(getattr(cls, hook) is getattr(Effect, hook) or
                   getattr(cls, f"d_{hook}") is not getattr(Effect, f"d_{hook}") for hook in HOOKS)

    def _identity(self, hook: str, value: np.ndarray, tangent: Tangent) -> tuple[np.ndarray, Tangent]:
        if getattr(type(self), hook) is not getattr(Effect, hook):
            raise NotImplementedError(f"effect {self.name!r} overrides {hook} without d_{hook}: "
                                      "its derivatives are taken by finite differences")
        return value, tangent

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._identity("effective_distance", x_m, dx)

    def d_winding_temperature(self, t_c: np.ndarray, dt: Tangent, data: Measurements,
                              p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._identity("winding_temperature", t_c, dt)

    def d_target_temperature(self, t_c: np.ndarray, dt: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._identity("target_temperature", t_c, dt)

    def d_target_tau(self, tau_s: np.ndarray, dtau: Tangent, inputs: Inputs, d_inputs: InputTangents,
                     data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._identity("target_tau", tau_s, dtau)

    def d_coupling_squared(self, k2: np.ndarray, dk2: Tangent, inputs: Inputs, d_inputs: InputTangents,
                           data: Measurements, p: Mapping[str, float],
                           coupling_hat_tangent: Callable[[np.ndarray, Tangent], tuple[np.ndarray, Tangent]]
                           ) -> tuple[np.ndarray, Tangent]:
        """``coupling_squared`` and its tangent; ``coupling_hat_tangent(x_m, dx)`` gives Eq. (5) and its tangent at
        any distances whose tangent is ``dx``."""
        return self._identity("coupling_squared", k2, dk2)

    def d_coil_inductance(self, l_h: np.ndarray, dl: Tangent, inputs: Inputs, d_inputs: InputTangents,
                          data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._identity("coil_inductance", l_h, dl)

    def d_series_inductance(self, l_h: np.ndarray, dl: Tangent, inputs: Inputs, d_inputs: InputTangents,
                            data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._identity("series_inductance", l_h, dl)

    def d_coil_capacitance(self, c_f: np.ndarray, dc: Tangent, inputs: Inputs, d_inputs: InputTangents,
                           data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._identity("coil_capacitance", c_f, dc)

    def d_parallel_conductance(self, g_s: np.ndarray, dg: Tangent, inputs: Inputs, d_inputs: InputTangents,
                               data: Measurements, p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        return self._identity("parallel_conductance", g_s, dg)


#: The stage hooks an effect may override (each with its derivative hook ``d_<hook>``).
HOOKS = ("effective_distance", "winding_temperature", "target_temperature", "target_tau", "coupling_squared",
         "coil_inductance", "series_inductance", "coil_capacitance", "parallel_conductance")


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator for effects: checks the class has a name (the library lists its classes in
    ``ecds_lab.model.library.LIBRARY``; a user's file needs no decorator). Returns the class."""
    if not cls.name:
        raise ValueError(f"effect class {cls.__name__} has no name")
    return cls


class EffectRegistry:
    """The effects a fit or a diagnosis may use: name -> class, names unique.

    Passed as an object (``SensorModel``, ``fit``, ``run_diagnosis`` take one), so a user's effects
    or a test's join only the registry they are added to."""

    def __init__(self, classes: Iterable[type[Effect]] = ()) -> None:
        self._classes: dict[str, type[Effect]] = {}
        for cls in classes:
            self.add(cls)

    def add(self, cls: type[Effect], origin: str = "") -> None:
        """Enter an effect class under its name; the same class twice is a no-op, another class under a
        taken name an error naming both."""
        register(cls)
        taken = self._classes.get(cls.name)
        if taken is cls:
            return
        if taken is not None:
            where = f"{origin}: " if origin else ""
            raise ValueError(f"{where}effect name {cls.name!r} is registered twice (already taken by "
                             f"{taken.__module__}.{taken.__qualname__})")
        self._classes[cls.name] = cls

    def with_effects(self, *classes: type[Effect]) -> EffectRegistry:
        """A new registry: these effects and the given classes (this one unchanged)."""
        out = EffectRegistry(self._classes.values())
        for cls in classes:
            out.add(cls)
        return out

    def names(self) -> list[str]:
        return list(self._classes)

    def get(self, name: str) -> type[Effect] | None:
        return self._classes.get(name)

    def __getitem__(self, name: str) -> type[Effect]:
        return self._classes[name]

    def __contains__(self, name: object) -> bool:
        return name in self._classes

    def __iter__(self) -> Iterator[str]:
        return iter(self._classes)

    def __len__(self) -> int:
        return len(self._classes)

    def make(self, name: str, sensor: SensorConfig) -> Effect:
        """An effect by name; unknown names fail listing the known ones."""
        cls = self._classes.get(name)
        if cls is not None:
            return cls(sensor)
        known = ", ".join(sorted(self._classes)) or "none yet"
        if name in EFFECT_NAMES:
            raise ValueError(f"effect {name!r} is a known effect name but not implemented; implemented: {known}")
        raise ValueError(f"unknown effect {name!r}; known effects: {known} (add your own with --effects-from "
                         "FILE.py or an installed package's 'ecds_lab.effects' entry point)")


def library() -> EffectRegistry:
    """A new registry of the library's effects and those installed packages declare (entry points)."""
    from ecds_lab.model.library import LIBRARY
    from ecds_lab.model.plugins import entry_point_effects

    registry = EffectRegistry(LIBRARY)
    for cls, origin in entry_point_effects():
        try:
            registry.add(cls, origin)
        except ValueError as exc:  # an installed package must not stop the analysis of data that do not need it
            log.warning("%s", exc)
    return registry


def make_effect(name: str, sensor: SensorConfig, registry: EffectRegistry | None = None) -> Effect:
    """An effect by its name, from ``registry`` (default: ``library()``); unknown names fail listing the known ones."""
    return (registry if registry is not None else library()).make(name, sensor)
