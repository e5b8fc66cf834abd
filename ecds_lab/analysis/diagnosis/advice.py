"""Suggested measurements that know the campaign: never one the data already contain.

Each effect's ``reveal`` says what measurement shows it best, and ``reveal_needs`` what a campaign must
hold for that (``Effect.reveal_needs``: two frequencies with the target hot, both directions, a long
hold of the coil hot...). The campaign's design is read from the data (``Design``); a reveal whose
needs the data already meet is not suggested again (the data would then already have separated the
effects, were they large enough: more readings, not another design, are the way on).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ecds_lab.analysis.diagnosis.checks import DRIFT_CHECKS
from ecds_lab.analysis.diagnosis.result import Diagnosis
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.ecm import self_resonance_hz
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.model.library.magnetic_depth import lowest_frequency_hz

#: A reading is "hot" this far (K) above the campaign's coldest reading of the same sensor.
HOT_K = 5.0
#: A hold: the coil within this band (K) of one temperature, at least HOT_K above the coldest.
HOLD_BAND_K = 2.0
#: The two frequencies the bridge measures the paper's sensor at (Hz).
USUAL_FREQUENCIES_HZ = (500.0, 15000.0)
#: Second frequencies for a steel plate above 15 kHz: the highest at most RESONANCE_SHARE of the coil's
#: self-resonance 1/(2 pi sqrt(L C_p)) (the paper's coil: 97 kHz, so 50 kHz, where the faithful steel plate was
#: fitted to its noise: docs/physics.md, "A magnetic plate"); nearer the resonance C_p's share of L grows fast.
STEEL_HIGHER_HZ = (50000.0, 40000.0, 30000.0, 20000.0)
RESONANCE_SHARE = 0.6
#: Why one frequency cannot decide (the second frequency's advice).
TIED = "with one frequency tau_T and the coupling are tied together"


@dataclass(frozen=True)
class Design:
    """What a campaign holds, from its data: the keys of ``Effect.reveal_needs``."""

    frequencies: int
    frequencies_target_hot: int
    directions: int
    target_span_k: float
    coil_span_k: float
    hold_s: float
    finest_step_mm: float
    present_hz: tuple[float, ...]

    @classmethod
    def of(cls, data: Measurements) -> Design:
        finite = np.isfinite(data.x_m)
        target_hot = data.t_target_c > (data.t_target_c.min() + HOT_K if len(data) else 0.0)
        positions = np.unique(np.round(data.x_commanded_m[finite] * 1e3, 3))
        steps = np.diff(positions)
        return cls(len(np.unique(data.freq_hz)), len(np.unique(data.freq_hz[target_hot & finite])),
                   len(np.unique(data.direction[finite & (data.direction != 0)])),
                   float(np.ptp(data.t_target_c)) if len(data) else 0.0,
                   float(np.ptp(data.t_coil_c)) if len(data) else 0.0, _longest_hold_s(data),
                   float(steps.min()) if len(steps) else float("inf"),
                   tuple(float(f) for f in np.unique(data.freq_hz)))

    def meets(self, needs: dict[str, float]) -> bool:
        """Whether the campaign holds everything ``needs`` asks (``finest_step_mm``: at most; others: at least)."""
        for key, wanted in needs.items():
            have = getattr(self, key)
            if (have > wanted) if key == "finest_step_mm" else (have < wanted):
                return False
        return True


def _longest_hold_s(data: Measurements) -> float:
    """The longest stretch (s) of one recording the coil stays within HOLD_BAND_K of one temperature while hot."""
    if not len(data):
        return 0.0
    hot = data.t_coil_c >= data.t_coil_c.min() + HOT_K
    longest = 0.0
    for rows in data.segment_rows:
        rows = rows[np.argsort(data.time_s[rows], kind="stable")]
        start = None
        for i in rows:
            if not hot[i]:
                start = None
                continue
            if start is None or abs(data.t_coil_c[i] - data.t_coil_c[start]) > HOLD_BAND_K:
                start = i
            longest = max(longest, float(data.time_s[i] - data.time_s[start]))
    return longest


def suggestions(result: Diagnosis, registry: EffectRegistry) -> list[str]:
    """Measurements that would separate the alternatives or determine an undetermined effect (each
    effect's ``reveal``), de-duplicated, without those the campaign already holds; and for an effect of the final
    round that failed only because a slow drift in time explains what it took as well, the measurement that tells
    the two apart (``Effect.reveal_beside_drift``)."""
    design = Design.of(result.data)
    groups = [*result.alternatives, *([result.undetermined] if result.undetermined else [])]
    out: list[str] = []
    for group in groups:
        for name in group:
            cls = registry.get(name)
            if cls is None or not cls.reveal or design.meets(cls.reveal_needs):
                continue
            if cls.reveal not in out:
                out.append(cls.reveal)
    for candidate in result.steps[-1].candidates:  # failed only for what a slow drift would leave as well
        failed = candidate.failed
        text = candidate.effect_object.reveal_beside_drift
        if failed and failed <= DRIFT_CHECKS and text and text not in out:
            out.append(text)
    if design.frequencies < 2 and groups:
        text = another_frequency(design, result.final.fit.model.sensor)
        if text not in out:
            out.insert(0, text)
    return out


def another_frequency(design: Design, sensor: SensorConfig) -> str:
    """The second frequency a one-frequency campaign should add: the paper's other one, or on a steel plate the
    next at which its screening depth's law holds (``magnetic_depth.lowest_frequency_hz``; docs/physics.md, "A
    magnetic plate"), below the coil's self-resonance: at 500 Hz its magnetisation and eddy currents nearly cancel
    and no first-order law holds."""
    lowest = lowest_frequency_hz(sensor)
    if lowest <= 0.0:
        other = next((f for f in USUAL_FREQUENCIES_HZ if f not in design.present_hz), USUAL_FREQUENCIES_HZ[0])
        return f"measure at {other:g} Hz as well: {TIED}"
    resonance = self_resonance_hz(sensor.inductance_h, sensor.capacitance_f)
    higher = next((f for f in STEEL_HIGHER_HZ if f <= RESONANCE_SHARE * resonance), STEEL_HIGHER_HZ[-1])
    other = next((f for f in (*USUAL_FREQUENCIES_HZ, higher) if f >= lowest and f not in design.present_hz), higher)
    return (f"measure at {other:g} Hz as well: {TIED} (on a magnetic plate from about {lowest / 1e3:.0f} kHz up, "
            f"where its screening depth's law holds; at 500 Hz its magnetisation and eddy currents nearly cancel)")
