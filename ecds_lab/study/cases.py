"""The validation study's cases: a random truth (which imperfections the simulated lab has, how large)
and a random campaign design (frequencies, directions, length, heating), drawn from one seed.

The truths are the simulated lab's imperfections by their documented names and sizes
(docs/simulated_lab.md), switched on in its station YAML block; nothing here knows how either the lab
or the analysis computes them. Each truth says which library effect names it (``expects``; an empty
tuple: no library effect does, it lies outside the library), which effect it may honestly be tied with
at one frequency, and which campaign designs can reveal it at all.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: Frequencies (Hz) the designs choose from: the paper's pair.
LOW_HZ, HIGH_HZ = 500.0, 15000.0


@dataclass(frozen=True)
class Design:
    """What a campaign measures: the experimenter's choices, before any truth."""

    frequencies_hz: tuple[float, ...]
    directions: tuple[str, ...]
    positions: int  # coarse positions over 20-100 mm
    fine_steps: bool  # plus 0.75 mm steps over 30-45 mm (resolves a screw's lead)
    target_setpoints_c: tuple[float, ...]
    coil_setpoints_c: tuple[float, ...]
    repeats: int

    @property
    def both_directions(self) -> bool:
        return len(self.directions) == 2

    @property
    def two_frequencies(self) -> bool:
        return len(self.frequencies_hz) == 2

    def to_json(self) -> dict[str, Any]:
        return {"frequencies_hz": list(self.frequencies_hz), "directions": list(self.directions),
                "positions": self.positions, "fine_steps": self.fine_steps,
                "target_setpoints_c": list(self.target_setpoints_c),
                "coil_setpoints_c": list(self.coil_setpoints_c), "repeats": self.repeats}


@dataclass(frozen=True)
class TruthKind:
    """One imperfection of the simulated lab: its YAML block, how to size it, what should name it."""

    name: str
    #: the station YAML's ``simulated: lab:`` change that switches it on, given a random generator
    block: Callable[[np.random.Generator], dict[str, Any]]
    #: library effects that name it (empty: it lies outside the library)
    expects: tuple[str, ...]
    #: whether a campaign of this design can reveal it at all
    revealed_by: Callable[[Design], bool]
    #: library effects it may honestly be tied with (named as alternatives) when the design cannot separate them
    tied_with: tuple[str, ...] = ()
    #: where the residual of a truth outside the library lives (association variables any of which is right)
    lives_in: tuple[str, ...] = ()
    #: noise, not an effect: the right answer is to claim nothing for it
    nuisance: bool = False


def _heated_target(design: Design) -> bool:
    return bool(design.target_setpoints_c)


def _heated_coil(design: Design) -> bool:
    return bool(design.coil_setpoints_c)


LIBRARY_TRUTHS: tuple[TruthKind, ...] = (
    TruthKind("bending", lambda g: {"plate": {"bending": {"enabled": True,
                                                         "centre_rise_um_per_k": float(g.uniform(0.4, 1.6))}}},
              ("target_bending",), _heated_target, tied_with=("target_tau_temperature",)),
    TruthKind("conductivity", lambda g: {"plate": {"conductivity": {"enabled": True}}},
              ("target_tau_temperature",), _heated_target, tied_with=("target_bending",)),
    TruthKind("backlash", lambda g: {"slide": {"backlash": {"enabled": True,
                                                           "backlash_um": float(g.uniform(15.0, 60.0))}}},
              ("slide_backlash",), lambda d: d.both_directions),
    TruthKind("lead_screw", lambda g: {"slide": {"lead_screw": {"enabled": True,
                                                               "amplitude_um": float(g.uniform(8.0, 20.0)),
                                                               "pitch_mm": float(g.uniform(2.0, 10.0))}}},
              ("slide_lead_screw",), lambda d: d.fine_steps),
    TruthKind("expansion", lambda g: {"former": {"expansion": {"enabled": True}}},
              ("former_expansion",), _heated_coil),
    TruthKind("moisture", lambda g: {"former": {"moisture": {"enabled": True, "initial": 1.0}}},
              ("parasitic_capacitance",), _heated_coil),
    TruthKind("glitches", lambda g: {"bridge": {"glitches": {"enabled": True,
                                                            "rate_per_reading": float(g.uniform(5e-4, 3e-3))}}},
              (), lambda d: True, nuisance=True),
    TruthKind("repeatability", lambda g: {"slide": {"repeatability": {"enabled": True,
                                                                     "sigma_um": float(g.uniform(2.0, 8.0))}}},
              (), lambda d: True, nuisance=True),
)

def _signed(g: np.random.Generator, low: float, high: float) -> float:
    return float(g.uniform(low, high) * g.choice([-1.0, 1.0]))


#: The paper prototype's winding rim (outer radius, mm), beside which a metal object's block places it.
PAPER_RIM_MM = 75.0


def _metal_object(g: np.random.Generator) -> dict[str, Any]:
    """A bracket anywhere in the travel, clearing the winding's rim by 0.5-6 mm (docs/simulated_lab.md); placed
    by the paper prototype's rim, moved to another sensor's own by ``SensorKind.placed``."""
    radius_mm = float(g.uniform(2.5, 5.0))
    return _imperfection("metal_object", position_mm=float(g.uniform(30.0, 90.0)), radius_mm=radius_mm,
                         radial_mm=PAPER_RIM_MM + radius_mm + float(g.uniform(0.5, 6.0)))


def _imperfection(name: str, **settings: Any) -> dict[str, Any]:
    return {"imperfections": {name: {"enabled": True, **settings}}}


#: Imperfections of the wider world, by their names and typical sizes in docs/simulated_lab.md; no library
#: effect describes them. Two of them act through a documented part that is then on as well (the former's
#: expansion, its moisture), so the library effect of that part may be claimed beside them.
WIDER_TRUTHS: tuple[TruthKind, ...] = (
    TruthKind("gain_drift", lambda g: _imperfection("bridge_gain_drift", ppm_per_hour=_signed(g, 100.0, 300.0),
                                                   wander_ppm=float(g.uniform(0.0, 20.0))),
              (), lambda d: bool(d.target_setpoints_c or d.coil_setpoints_c), lives_in=("time_s",)),
    TruthKind("heater_pickup", lambda g: _imperfection("bridge_heater_pickup", ppm_per_ampere={
        "fast": 100.0, "medium": 30.0, "slow": float(g.uniform(5.0, 30.0))}), (), lambda d: True, nuisance=True),
    # a bump of 15 mm full width in x is told from a smooth calibration only with positions at most a third of
    # that apart (16 over 20-100 mm); nine positions 10 mm apart put one or two readings in it
    TruthKind("metal_object", lambda g: _metal_object(g),
              (), lambda d: d.positions >= 16, lives_in=("x_mm",)),
    TruthKind("target_tilt", lambda g: _imperfection("target_tilt", tilt_urad_per_k=_signed(g, 5.0, 30.0),
                                                    pivot_mm=float(g.uniform(50.0, 150.0))),
              (), _heated_target, lives_in=("t_target_c",),
              # about a pivot off the coil's axis, a tilt brings the plate nearer in proportion to its
              # temperature rise: the observable a bending describes (the shape across the face is below
              # the noise), so naming a bending for it is not a wrong claim
              tied_with=("target_bending", "target_tau_temperature")),
    TruthKind("expansion_hysteresis", lambda g: {**_imperfection("expansion_hysteresis",
                                                                 width_k=float(g.uniform(3.0, 8.0))),
                                                 "former": {"expansion": {"enabled": True}}},
              (), _heated_coil, lives_in=("t_coil_c", "coil_rate_k_per_min", "time_s"),
              tied_with=("former_expansion",)),
    TruthKind("reabsorption", lambda g: {**_imperfection("reabsorption",
                                                         relative_humidity=float(g.uniform(0.3, 0.8)),
                                                         groove_uptake_tau_s=float(g.uniform(1200.0, 7200.0))),
                                         "former": {"moisture": {"enabled": True, "initial": 1.0}}},
              (), _heated_coil, lives_in=("time_s", "t_coil_c", "coil_rate_k_per_min"),
              tied_with=("parasitic_capacitance",)),
)

#: Effects that are true of the faithful lab whatever the truth drawn: the field solution's tau_T(x) at
#: two frequencies, and the winding's lag behind the former's thermocouple while the coil's temperature moves.
ALWAYS_TRUE: dict[str, Callable[[Design], bool]] = {
    "tau_displacement": lambda d: d.two_frequencies,
    "thermal_lag": _heated_coil,
}


@dataclass(frozen=True)
class SensorKind:
    """A sensor the study can measure: the simulated lab's geometry for it (docs/simulated_lab.md) and the sensor
    description the analysis is given (the fields of a sensor YAML), as a user would write both."""

    name: str
    #: the station YAML's ``simulated: lab:`` change that builds it
    lab: dict[str, Any] = field(default_factory=dict, hash=False)
    #: its sensor YAML (the paper's prototype where empty)
    sensor: dict[str, Any] = field(default_factory=dict, hash=False)
    #: the frequencies it is measured at whatever the design asks (None: the design's)
    frequencies_hz: tuple[float, ...] | None = None
    #: library effects its physics makes true whatever the truth drawn
    always_true: tuple[str, ...] = ()

    @property
    def rim_mm(self) -> float:
        """The outer radius of its winding (mm)."""
        return 1e3 * float(self.lab.get("coil", {}).get("outer_radius_m", PAPER_RIM_MM / 1e3))

    def placed(self, blocks: dict[str, Any]) -> dict[str, Any]:
        """``blocks`` with a metal object moved from the paper prototype's rim to this winding's, at the same
        clearance: drawn beside the paper's 75 mm rim, a bracket would sit 45 mm beyond a 30 mm coil's."""
        bracket = blocks.get("imperfections", {}).get("metal_object")
        if bracket is None or self.rim_mm == PAPER_RIM_MM:
            return blocks
        return merged(blocks, {"imperfections": {"metal_object": {
            "radial_mm": bracket["radial_mm"] - PAPER_RIM_MM + self.rim_mm}}})


#: A coil of a fifth of the paper's winding radius (20-30 mm, 2 mm high, 300 turns), as commercial ECDSs' are
#: small against the paper's: over the same 5 mm copper plate and 20-100 mm travel it reaches 0.7-3.3 of its radius.
SMALL_COIL = {"inner_radius_m": 0.02, "outer_radius_m": 0.03, "height_m": 0.002, "turns": 300}

#: The sensors a study may draw (``--sensors``): the paper's prototype over its 5 mm copper plate (the default and
#: the study's yardstick), the same coil over steel (measured at 15 kHz, as the paper measured it: at 500 Hz the
#: plate's magnetisation and eddy currents nearly cancel, which no first-order law describes; its screening from a
#: complex depth, ``magnetic_depth``, is true of every steel campaign), over a copper sheet of 1 mm (a third of
#: the skin depth at 500 Hz), and over plates of the other non-magnetic metals a sensor YAML may name, 5 mm of
#: aluminium and of brass (docs/simulated_lab.md: brass's skin depth at 500 Hz is longer than the plate is thick),
#: and a small coil over the copper plate (a metal object then clears its own rim).
SENSORS: dict[str, SensorKind] = {kind.name: kind for kind in (
    SensorKind("paper"),
    SensorKind("steel", sensor={"target": "steel"}, frequencies_hz=(HIGH_HZ,), always_true=("magnetic_depth",)),
    SensorKind("thin_plate", lab={"plate": {"thickness_m": 1e-3}}),
    SensorKind("aluminium", sensor={"target": "aluminium"}),
    SensorKind("brass", sensor={"target": "brass"}),
    SensorKind("small_coil", lab={"coil": SMALL_COIL}, sensor={"coil": SMALL_COIL}),
)}


@dataclass(frozen=True)
class Case:
    """One campaign of the study: its number, seed, design, truth and sensor."""

    number: int
    seed: int
    design: Design
    truths: tuple[str, ...]
    blocks: dict[str, Any] = field(hash=False)
    sensor: str = "paper"

    def to_json(self) -> dict[str, Any]:
        return {"case": self.number, "seed": self.seed, "design": self.design.to_json(),
                "truths": list(self.truths), "lab": self.blocks, "sensor": self.sensor}


def truth_kinds() -> dict[str, TruthKind]:
    """Every truth the study can draw, by name."""
    return {kind.name: kind for kind in (*LIBRARY_TRUTHS, *WIDER_TRUTHS)}


def draw_design(rng: np.random.Generator) -> Design:
    """A campaign design as an experimenter might choose it."""
    short = bool(rng.random() < 0.5)
    heating = rng.choice(["none", "target", "coil", "both"], p=[0.2, 0.35, 0.25, 0.2])
    return Design(
        frequencies_hz=(HIGH_HZ,) if rng.random() < 0.4 else (LOW_HZ, HIGH_HZ),
        directions=("forward",) if rng.random() < 0.35 else ("forward", "backward"),
        positions=9 if short else 16,
        fine_steps=bool(rng.random() < 0.3),
        target_setpoints_c=() if heating in ("none", "coil") else ((75.0,) if short else (75.0, 130.0)),
        coil_setpoints_c=() if heating in ("none", "target") else ((60.0, 120.0) if short else (40.0, 80.0, 120.0)),
        repeats=1 if rng.random() < 0.6 else 2,
    )


def merged(base: dict[str, Any], change: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``change`` laid over it, nested blocks merged key by key."""
    out = dict(base)
    for key, value in change.items():
        out[key] = merged(out.get(key, {}), value) if isinstance(value, dict) else value
    return out


def draw_case(number: int, seed: int, sensors: Sequence[str] = ("paper",)) -> Case:
    """Case ``number`` of the study with ``seed``: none, one, two or three imperfections, a random design, on one
    of ``sensors`` (drawn apart: the truth and design of a case are the same whichever sensors may be drawn)."""
    unknown = [name for name in sensors if name not in SENSORS]
    if unknown or not sensors:
        raise ValueError(f"unknown sensor(s) {', '.join(unknown) or '(none given)'}; known: {', '.join(SENSORS)}")
    rng = np.random.default_rng([seed, number])
    design = draw_design(rng)
    kinds = truth_kinds()
    count = int(rng.choice([0, 1, 2, 3], p=[0.3, 0.35, 0.25, 0.1]))
    names = sorted(rng.choice(sorted(kinds), size=min(count, len(kinds)), replace=False).tolist())
    blocks: dict[str, Any] = {}
    for name in names:
        blocks = merged(blocks, kinds[name].block(rng))
    sensor = SENSORS[sensors[int(np.random.default_rng([seed, number, 1]).integers(len(sensors)))]]
    if sensor.frequencies_hz is not None:
        design = dataclasses.replace(design, frequencies_hz=sensor.frequencies_hz)
    return Case(number, int(rng.integers(2**31)), design, tuple(names), sensor.placed(blocks), sensor.name)


def draw_cases(count: int, seed: int, sensors: Sequence[str] = ("paper",)) -> list[Case]:
    """The study's ``count`` cases from one seed (case i is the same whatever the count)."""
    return [draw_case(i, seed, sensors) for i in range(count)]
