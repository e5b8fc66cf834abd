"""What the report shows, computed from its inputs: fits, diagnosis, calibrations, heating, spectroscopy.

Every part the data cannot support is an ``Omitted`` carrying the one-line reason the report
prints instead. Readings are grouped by target material (a copper and a steel target cannot
share one model); coil-in-air recordings belong to every group, since the coil alone does not
depend on the target. The main group (copper when present) gets the residual maps and the
diagnosis.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ecds_lab.analysis.calibration import room_temperature_rows
from ecds_lab.analysis.compensation import SteadyEq4, TemperatureCompensation, fit_coil_temperature, fit_steady_eq4
from ecds_lab.analysis.fitting import FitResult, fit_model
from ecds_lab.analysis.noise import REPEATED
from ecds_lab.analysis.quantities import full_scale_mm
from ecds_lab.analysis.spectroscopy import RlcFit, fit_parallel_rlc
from ecds_lab.analysis.summary import CalibrationCase, CoilInputs, calibration_cases
from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.model.sensor_model import SensorModel
from ecds_lab.report.inputs import DEFAULT_TARGET, SPECTROSCOPY_MIN_FREQUENCIES, ReportInput

log = logging.getLogger("ecds_lab.report")

#: A coil-in-air recording must span this many kelvin of coil temperature to characterise heating.
MIN_HEATING_SPAN_K = 10.0
#: A frequency is calibrated only where bridge noise alone costs less than this share of full scale
#: (median over the sweep's positions): a steel target at 500 Hz hardly changes L at all.
MAX_NOISE_ERROR_FS = 0.01


@dataclass
class Omitted:
    """A part of the report the data cannot support, and why (one line)."""

    reason: str


@dataclass
class TargetGroup:
    """The readings of one target material, the baseline fit and the calibrations per frequency."""

    material: str
    sources: list[str]
    data: Measurements
    fit: FitResult
    cases: dict[float, list[CalibrationCase]] = field(default_factory=dict)
    coil_from_air: bool = False
    #: frequency -> why it was not calibrated
    skipped: dict[float, str] = field(default_factory=dict)
    #: frequency -> the paper's Eq. (4) from the steady coil temperatures in air
    eq4: dict[float, SteadyEq4] = field(default_factory=dict)

    @property
    def has_target(self) -> bool:
        return bool(np.isfinite(self.data.x_m).any())


@dataclass
class CoilHeating:
    """Eq. (4) fitted to the coil-in-air readings of every input."""

    data: Measurements
    compensation: TemperatureCompensation
    #: frequency -> the paper's Eq. (4) from the steady coil temperatures at that frequency
    eq4: dict[float, SteadyEq4] = field(default_factory=dict)


@dataclass
class Spectrum:
    """One impedance spectrum (a pass over the frequencies) and its parallel RLC fit."""

    source: str
    data: Measurements
    fit: RlcFit


@dataclass
class Findings:
    inputs: list[ReportInput]
    groups: list[TargetGroup] | Omitted
    #: a Diagnosis (``ecds_lab.analysis.diagnosis``), Omitted, or None until ``diagnose`` ran
    diagnosis: Any
    heating: CoilHeating | Omitted
    spectra: list[Spectrum] | Omitted
    #: material -> a Diagnosis or Omitted, for every target group after the main one (``diagnose`` sets them)
    others: dict[str, Any] = field(default_factory=dict)

    @property
    def main(self) -> TargetGroup | None:
        return self.groups[0] if isinstance(self.groups, list) and self.groups else None


def find(inputs: list[ReportInput]) -> Findings:
    """Everything the report shows except the diagnosis (``diagnose`` adds it: it takes longest)."""
    model_inputs = [i for i in inputs if len(i.data) and not i.is_spectroscopy]
    groups = target_groups(model_inputs)
    heating = coil_heating(model_inputs)
    if isinstance(groups, list):
        for group in groups:
            calibrations(group, heating)
    return Findings(inputs, groups, None, heating, spectra_of(inputs))


def diagnose(findings: Findings, given: Any = None, registry: EffectRegistry | None = None) -> None:
    """Set ``findings.diagnosis``: ``given`` (a Diagnosis of the main group's readings), else run one over
    ``registry``'s effects (an ``EffectRegistry``; default the library and installed packages'); and diagnose
    every other target group like it (``findings.others``): a target whose model fails is diagnosed too."""
    main = findings.main
    if given is not None:
        findings.diagnosis = given
    elif main is None:
        reason = findings.groups.reason if isinstance(findings.groups, Omitted) else "no data for the model"
        findings.diagnosis = Omitted(reason)
    else:
        findings.diagnosis = run_diagnosis_of(main, registry)
    groups = findings.groups if isinstance(findings.groups, list) else []
    findings.others = {g.material: run_diagnosis_of(g, registry) if g.has_target else
                       Omitted(f"no readings with the {g.material} target present") for g in groups[1:]}


def target_groups(inputs: list[ReportInput]) -> list[TargetGroup] | Omitted:
    """One fitted group per target material, the main one (copper if present, else the largest) first."""
    if not inputs:
        return Omitted("no data for the sensor model: no readings, or only spectroscopy recordings")
    with_target = [i for i in inputs if np.isfinite(i.data.x_m).any()]
    coil_only = [i for i in inputs if i not in with_target]
    materials = sorted({i.target for i in with_target}) or [DEFAULT_TARGET]
    groups = []
    for material in materials:
        members = [i for i in inputs if i in coil_only or (i in with_target and i.target == material)]
        data = Measurements.concatenate([i.data for i in members])
        model = SensorModel(next((i.sensor for i in members if i.target == material), SensorConfig(target=material)))
        groups.append(TargetGroup(material, [i.name for i in members], data, fit_model(model, data)))
    groups.sort(key=lambda g: (g.material != DEFAULT_TARGET, -len(g.data)))
    return groups


def calibrations(group: TargetGroup, heating: CoilHeating | Omitted) -> None:
    """Paper-style calibrations per frequency (n = all and n = 4) into ``group.cases``: the same
    ``summary.calibration_cases`` (and ``CoilInputs``) as ``ecds-lab fit``, so both show one number."""
    data = group.data
    if not group.has_target:
        return
    sweep = data.select(room_temperature_rows(data) & np.isfinite(data.x_m))
    coil = CoilInputs.of(data, group.fit.model.sensor.reference_temperature_c)
    group.eq4 = coil.eq4
    for freq in data.frequencies_hz:
        at_f = sweep.select(sweep.freq_hz == freq)
        fs_mm = full_scale_mm(at_f.x_mm)
        error_mm = noise_limited_error_mm(group.fit, at_f) if fs_mm > 0 else 0.0
        if fs_mm > 0 and error_mm > MAX_NOISE_ERROR_FS * fs_mm:
            group.skipped[float(freq)] = (f"{group.material} target at {freq:g} Hz not calibrated: L hardly depends "
                                          f"on x there (bridge noise alone would mean a {error_mm:.3g} mm position "
                                          f"error at a typical position, {error_mm / fs_mm:.0%} of FS)")
            continue
        found = calibration_cases(data, group.fit.model, group.fit, float(freq), coil=coil)
        if found:
            group.cases[float(freq)] = found
    group.coil_from_air = coil.heated is not None and any(c.coil_compensated for cs in group.cases.values()
                                                           for c in cs)


def noise_limited_error_mm(fit: FitResult, sweep: Measurements) -> float:
    """Median over a sweep's readings of noise * L / |dL/dx| (mm): the noise repeated readings show, else the RMS."""
    if not len(sweep):
        return 0.0
    noise = fit.noise.reading_ppm if fit.noise.method == REPEATED else fit.rms_ppm
    slope = fit.model.sensitivity(sweep, fit.values)
    with np.errstate(divide="ignore"):
        error_m = noise * 1e-6 * sweep.ls_h / np.abs(slope)
    return float(np.median(error_m) * 1e3)


def coil_heating(inputs: list[ReportInput]) -> CoilHeating | Omitted:
    """Eq. (4) on every coil-in-air reading, when they span enough coil temperature."""
    parts = [i.data.select(i.data.in_air) for i in inputs if i.data.in_air.any()]
    if not parts:
        return Omitted("no coil-heating data: no readings of the coil in air (x_mm = inf)")
    air = Measurements.concatenate(parts)
    span = float(np.ptp(air.t_coil_c))
    if span < MIN_HEATING_SPAN_K:
        return Omitted(f"no coil-heating data: the coil-in-air readings span {span:.1f} K of coil temperature "
                       f"(at least {MIN_HEATING_SPAN_K:.0f} K needed)")
    joint = fit_coil_temperature(air)
    eq4 = {float(f): e for f in air.frequencies_hz
           if (e := fit_steady_eq4(air, float(f), joint.reference_c)) is not None}
    return CoilHeating(air, joint, eq4)


def spectra_of(inputs: list[ReportInput]) -> list[Spectrum] | Omitted:
    """Parallel RLC fits of every spectrum in the spectroscopy inputs."""
    spectra, failures = [], []
    for item in inputs:
        if not item.is_spectroscopy:
            continue
        air = item.data.select(item.data.in_air)
        for rows in split_spectra(air):
            part = air.select(rows)
            if len(np.unique(part.freq_hz)) < SPECTROSCOPY_MIN_FREQUENCIES:
                continue
            try:
                fit = fit_parallel_rlc(part.freq_hz, part.ls_h, part.rs_ohm)
            except (ValueError, np.linalg.LinAlgError) as exc:
                failures.append(f"{item.name}: {exc}")
                continue
            fit.t_coil_c = float(np.mean(part.t_coil_c))
            spectra.append(Spectrum(item.name, part, fit))
    if not spectra:
        return Omitted(f"the parallel RLC fit failed ({'; '.join(failures)})" if failures else
                       f"no spectroscopy data: no input has coil-in-air readings at "
                       f"{SPECTROSCOPY_MIN_FREQUENCIES} or more frequencies")
    return spectra


def split_spectra(data: Measurements) -> list[np.ndarray]:
    """Row indices of each pass over the frequencies: a new pass starts where the frequency falls."""
    starts = np.flatnonzero((np.diff(data.freq_hz) < 0) | (np.diff(data.segment) != 0)) + 1
    return np.split(np.arange(len(data)), starts)


def run_diagnosis_of(group: TargetGroup, registry: EffectRegistry | None = None) -> Any:
    """The diagnosis of a target group's readings, or Omitted saying why there is none. It starts from the
    group's baseline fit (the report's): the same fit is not made twice."""
    try:
        from ecds_lab.analysis.diagnosis import run_diagnosis
    except ImportError as exc:
        return Omitted(f"the diagnosis is not available in this installation ({exc})")
    try:
        return run_diagnosis(group.data, sensor=group.fit.model.sensor, registry=registry, fitted=group.fit)
    except Exception as exc:
        log.warning("diagnosis failed", exc_info=True)
        return Omitted(f"the diagnosis failed: {type(exc).__name__}: {exc}")
