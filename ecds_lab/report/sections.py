"""The report's sections: what each shows from the findings, as HTML with embedded figures.

Order: runs; L(x) with the model fit and sensitivity; residual maps; diagnosis; position error
and temperature stability; coil heating; spectroscopy. A section, or a part of one, that the
data cannot support is replaced by a one-line note saying why.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import datetime
from itertools import pairwise
from typing import Any

import numpy as np

from ecds_lab.analysis.calibration import temperature_stability_ppm_fs_per_k
from ecds_lab.analysis.summary import HeatedErrors
from ecds_lab.data.sensor import DEFAULT_SENSOR_NOTE
from ecds_lab.report import figures_model as fm
from ecds_lab.report import figures_temperature as ft
from ecds_lab.report.findings import CoilHeating, Findings, Omitted, TargetGroup
from ecds_lab.report.inputs import ReportInput
from ecds_lab.report.markup import (
    Html,
    badge,
    lines,
    note,
    number,
    paragraph,
    side_by_side,
    table,
    value_error,
)
from ecds_lab.report.paper_section import paper_comparison_section
from ecds_lab.report.render import Plot

#: Residual plots of the diagnosis' chain show at most this many readings (drawn at random).
MAX_STEP_POINTS = 20_000
#: TS is quoted over the readings of the highest temperature step: rises above this share of the largest.
TOP_STEP_SHARE = 0.8

#: The paper's Table 1: temperature stability of commercial sensors and of the paper's demonstrator.
PAPER_TABLE_1 = (
    ("Micro-Epsilon EU80", "80 mm", "−40 … 200 °C", "< 150"),
    ("Kaman KDM-8206", "60 mm", "—", "1000 (compensated 200)"),
    ("ATO ECDS-5060", "50 mm", "—", "1000 (compensated 200)"),
    ("Gruber et al. 2024, coil heated", "100 mm", "20 … 130 °C", "< 22"),
    ("Gruber et al. 2024, target heated", "100 mm", "20 … 130 °C", "−11 … 18"),
)
#: The paper's Table 2: parallel RLC fits of the moist fired-clay coil.
PAPER_TABLE_2 = (("20 °C", "61", "62.5", "92"), ("65 °C", "60.4", "47.46", "212"),
                 ("120 °C", "58.4", "47.53", "984"))


#: Parameters shown in friendlier units: name -> (factor, unit).
DISPLAY_UNITS = {"L0": (1e3, "mH"), "alpha": (1e6, "ppm/K"), "beta": (1e6, "ppm/K²"), "tau_t": (1e6, "µs"),
                 "p1": (1e3, "mm"), "C_p": (1e12, "pF"), "R_p": (1e-3, "kΩ")}


#: A section's content: HTML and the figures to draw in place (see ``render``).
Parts = list[Html | Plot]


@dataclass
class Section:
    anchor: str
    title: str
    body: Parts

    def plots(self) -> list[Plot]:
        return [part for part in self.body if isinstance(part, Plot)]


DIAGNOSIS = "diagnosis"


def build_sections(findings: Findings, anchors: Sequence[str] | None = None) -> list[Section]:
    """The sections with the given anchors (default: all), in report order."""
    return [Section(anchor, title, build(findings)) for anchor, title, build in SECTIONS
            if anchors is None or anchor in anchors]


def anchors() -> list[str]:
    """Every section's anchor in report order."""
    return [anchor for anchor, _, _ in SECTIONS]


# -- runs ----------------------------------------------------------------------------------------
def _use_of(item: ReportInput, findings: Findings) -> str:
    if item.is_spectroscopy:
        return "spectroscopy"
    groups = findings.groups if isinstance(findings.groups, list) else []
    used = [g.material for g in groups if item.name in g.sources]
    return "model fit: " + ", ".join(f"{m} target" for m in used) if used else "—"


def _duration(item: ReportInput) -> str:
    lab = _hours_or_seconds(item.lab_duration_s)
    wall = item.run.wall_duration_s if item.run is not None else None
    if wall is None or abs(wall - item.lab_duration_s) < max(60.0, 0.05 * item.lab_duration_s):
        return lab
    return f"{lab} lab clock ({_hours_or_seconds(wall)} wall)"


def _hours_or_seconds(seconds: float) -> str:
    return f"{seconds / 3600:.2f} h" if seconds >= 3600 else f"{seconds:.0f} s"


def _started(run_start: str) -> str:
    try:
        return datetime.fromisoformat(run_start).strftime("%Y-%m-%d %H:%M:%S %Z").strip()
    except ValueError:
        return run_start or "—"


def runs_section(findings: Findings) -> Parts:
    runs = [i for i in findings.inputs if i.run is not None]
    csvs = [i for i in findings.inputs if i.run is None]
    parts: Parts = []
    if runs:
        run_identities = [i.run.identities for i in runs if i.run is not None]
        shared = all(ids == run_identities[0] for ids in run_identities)
        rows = []
        for item in runs:
            run = item.run
            assert run is not None
            points = f"{len(item.data)} readings"
            if run.planned_points is not None:
                points += f" of {run.points} rows; {run.planned_points} planned points"
            status = badge(run.status or "unknown", "good" if run.status == "completed" else "bad")
            row = [item.name, lines([run.experiment or "—", f"kind: {run.kind or '—'}"]),
                   lines([run.station or "—", f"target: {item.target}",
                          item.sensor_note or f"sensor: {item.sensor.name}"])]
            if not shared:
                row.append(lines([f"{role}: {ident}" for role, ident in sorted(run.identities.items())] or ["—"]))
            row += [status, lines([_started(run.start_time), _duration(item)]), points,
                    lines(run.faults) if run.faults else "none", _use_of(item, findings)]
            rows.append(row)
        header = ["file", "experiment", "station"] + ([] if shared else ["instruments"]) + [
            "status", "started / duration", "points", "faults", "used for"]
        parts.append(table(header, rows, css="runs"))
        identities = sorted(run_identities[0].items()) if shared else []
        if identities:
            parts.append(table(("role", "instrument identity"), identities,
                               caption=f"Instruments (the same in all {len(runs)} runs)" if len(runs) > 1
                               else "Instruments", css="instruments"))
    if csvs:
        parts.append(table(("CSV file", "rows", "used for"),
                           [(i.name, str(len(i.data)), _use_of(i, findings)) for i in csvs], css="runs"))
        parts.append(paragraph(f"A CSV holds readings only (no run metadata, no sensor): {DEFAULT_SENSOR_NOTE}.",
                               "small"))
    return parts


# -- model fit -----------------------------------------------------------------------------------
def _param_rows(fit: Any) -> list[tuple[str, str, str, str]]:
    """One row per parameter of a fit: name, value with its error, display unit, fitted or why fixed."""
    rows = []
    for p in fit.parameters:
        stderr = None if p.fixed else fit.stderr.get(p.name)
        how = fit.fixed.get(p.name, "fixed") if p.fixed else "fitted"
        scale, unit = DISPLAY_UNITS.get(p.name, (1.0, p.unit))
        rows.append((p.name, value_error(p.value, stderr, scale), unit, how))
    return rows


def _params_table(group: TargetGroup) -> Html:
    fit = group.fit
    rows = _param_rows(fit)
    noise = f", noise {fit.noise.ppm:.1f} ppm (from {fit.noise.source})"
    caption = (f"{group.material} target: baseline fit of {fit.n} readings, residual RMS {fit.rms_ppm:.1f} ppm of L"
               f"{noise}")
    return table(("parameter", "value", "unit", "status"), rows, caption=caption, css="params")


def fit_section(findings: Findings) -> Parts:
    if isinstance(findings.groups, Omitted):
        return [note(findings.groups.reason)]
    groups = findings.groups
    parts: Parts = [paragraph("Baseline model, the paper's Eq. (2) with Eq. (4) and the calibrated coupling Eq. (5), "
                       "fitted to all readings of each target material.")]
    with_target = [g for g in groups if g.has_target]
    if with_target:
        curves = [(g.material, g.fit, g.data) for g in with_target]
        parts.append(Plot(fm.inductance_vs_distance, (curves,),
                            "Measured inductance L(x) per frequency (like the paper's Fig. 6): markers are readings, "
                            "one colour per thermal state (target temperature); lines are the fitted model at that "
                            "state. Grey: readings of states with fewer than five positions (ramps)."))
        if max(fm.room_sweep_positions(g.data) for g in with_target) >= fm.MIN_SENSITIVITY_POSITIONS:
            parts.append(Plot(fm.sensitivity, (curves,),
                              "Sensitivity S = dL/dx at room temperature (like the paper's Fig. 7): the fitted model "
                              "(lines) and finite differences of the measured sweep (markers)."))
        else:
            parts.append(note(f"no sensitivity plot: no room-temperature sweep over "
                              f"{fm.MIN_SENSITIVITY_POSITIONS} or more positions"))
    else:
        parts.append(note("no L(x) or sensitivity plot: no readings with the target present (all coil in air)"))
    parts.append(Html('<div class="tables">' + "".join(_params_table(g) for g in groups) + "</div>"))
    return parts


def residual_section(findings: Findings) -> Parts:
    main = findings.main
    if main is None:
        return [note(findings.groups.reason if isinstance(findings.groups, Omitted) else "no model fit")]
    fit = main.fit
    air = int(main.data.in_air.sum())
    caption = (f"Residual of the baseline fit ({main.material} target, {fit.n} readings, RMS {fit.rms_ppm:.1f} ppm) "
               "against each variable (rows), coloured by each variable (columns; the panel whose colour is its "
               "own axis is grey); band: ± the noise. Structure in a row shows where the model fails; the "
               "colours show what it goes with."
               + (f" The {air} coil-in-air readings have no distance and are light grey where x is the colour."
                  if air else ""))
    rows = fm.MAP_AXES
    return [Plot(fm.residual_map_row, (main.data, fit.residuals_ppm, fit.noise_ppm, name, i == 0),
                 caption if i == len(rows) - 1 else "") for i, name in enumerate(rows)]


# -- diagnosis -----------------------------------------------------------------------------------
def diagnosis_section(findings: Findings) -> Parts:
    diagnosis = findings.diagnosis
    if isinstance(diagnosis, Omitted):
        return [note(diagnosis.reason)]
    main = findings.main
    verdict = str(diagnosis.verdict)
    parts: Parts = [Html(f'<p>{badge(verdict.replace("_", " "), "good" if verdict == "adequate" else "bad")} '
                  f"noise {diagnosis.noise_ppm:.1f} ppm ({diagnosis.noise.source}), baseline residual "
                  f"{diagnosis.baseline.rms_ppm:.1f} ppm of L ({main.material if main else ''} target data)</p>"),
             paragraph(diagnosis.explanation, "explanation")]
    steps = list(getattr(diagnosis, "steps", []))
    if steps:
        parts.append(_chain_table(steps))
    if diagnosis.outliers:
        parts.append(table(("row", "reading (mH)", "deviation (σ)", "reason"),
                           [(str(o.row), f"{o.value * 1e3:.6g}", f"{o.residual_sigma:+.1f}", o.reason)
                            for o in diagnosis.outliers],
                           caption="Readings excluded from the fit as glitches (rows of the campaign, 0-based)"))
    if diagnosis.alternatives or diagnosis.suggested_measurements:
        items = [" / ".join(group) for group in diagnosis.alternatives]
        parts.append(paragraph("The data cannot separate: " + "; ".join(items) + ". Suggested: "
                               + " ".join(f"{s}." for s in diagnosis.suggested_measurements), "explanation"))
    candidates = list(diagnosis.candidates)
    if candidates:
        parts.append(Plot(fm.candidate_ranking, ([c.effect for c in candidates], [c.rmse_ppm for c in candidates],
                                                 [c.delta_bic for c in candidates], diagnosis.baseline.rms_ppm,
                                                 diagnosis.noise_ppm),
                            "Each effect added to the given model in turn: residual RMS (left; dashed: "
                            "that model, dotted: noise) and ΔBIC (right; below zero the effect earns its extra "
                            "parameters). Passing candidates first."))
        rows = [(c.effect, number(c.rmse_ppm, 4), number(c.cv_rmse_ppm, 4), f"{c.delta_bic:+.1f}",
                 "passes" if c.passes else "; ".join(c.rejected)) for c in candidates]
        ranking = table(("effect", "RMS (ppm)", "held-out RMS (ppm)", "ΔBIC", "checks"), rows,
                        caption="Candidates against the given model")
        associations = table(("variable", "score", "detail"),
                             [(a.variable, f"{a.score:.2f}", a.detail) for a in diagnosis.associations],
                             caption="Where the final model's residual lives (share of it each variable explains)")
        parts.append(side_by_side(ranking, associations))
    elif getattr(diagnosis, "untestable", None):
        parts.append(table(("effect", "why these data cannot test it"), sorted(diagnosis.untestable.items()),
                           caption="No effect could be tested"))
    else:
        parts.append(note("no candidate ranking: the diagnosis tried no effects"))
    for before, after in pairwise(steps):
        parts.append(_step_plot(diagnosis, before, after))
    for i, step in enumerate(steps):
        parts.append(_step_params(step, "given model" if i == 0 else "+ " + step.effects[-1]))
    return parts


def _chain_label(effects: Sequence[str]) -> str:
    return " + ".join(["baseline", *effects])


def _chain_table(steps: Sequence[Any]) -> Html:
    """The chain baseline → +effect → …: RMS, position error (mm and % FS) and BIC of every model."""
    rows = [(_chain_label(s.effects) + _tie_note(s), number(s.rmse_ppm, 4), number(s.position_error_mm, 3),
             number(s.position_error_fs_pct, 3), f"{s.fit.bic:.1f}") for s in steps]
    return table(("model", "RMS (ppm of L)", "position error RMS (mm)", "position error (% FS)", "BIC"), rows,
                 caption="Watch the error fall: each step adds the effect the diagnosis claimed, or one that stands "
                         "for a group the data cannot tell apart (not claimed)", css="chain")


def _tie_note(step: Any) -> str:
    """For a step whose effect stands for a tied group: which group (none of it is claimed)."""
    group = getattr(step, "stands_for", None)
    return f" (stands for {' / '.join(group)}: not claimed)" if group else ""


def _step_plot(diagnosis: Any, before: Any, after: Any) -> Html | Plot:
    """Residuals of one step of the chain and of the next, against the most telling variables."""
    data = diagnosis.data
    r0, r1 = np.asarray(before.fit.residuals_ppm), np.asarray(after.fit.residuals_ppm)
    if not (len(data) == len(r0) == len(r1)):
        return note("no residual plot for this step: the residuals do not match the readings row by row")
    variables = [a.variable for a in diagnosis.associations if a.variable in fm.VARIABLES]
    added = after.effects[-1]
    for name in ("x_mm",):
        if name not in variables:
            variables.append(name)
    caption = (f"{_chain_label(before.effects)} (red) → + {added} (blue): RMS {before.rmse_ppm:.1f} → "
               f"{after.rmse_ppm:.1f} ppm, position error {number(before.position_error_mm, 3)} → "
               f"{number(after.position_error_mm, 3)} mm.")
    if len(data) > MAX_STEP_POINTS:  # a scatter of every reading of a huge campaign only costs time
        shown = np.sort(np.random.default_rng(0).choice(len(data), MAX_STEP_POINTS, replace=False))
        caption += f" {MAX_STEP_POINTS:,} of the {len(data):,} readings shown, at random."
        data, r0, r1 = data.select(shown), r0[shown], r1[shown]
    return Plot(fm.before_after, (data, r0, r1, added, variables, diagnosis.noise_ppm), caption)


def _step_params(step: Any, title: str) -> Html:
    """The parameter table of one model of the chain."""
    fit = step.fit
    rows = _param_rows(fit)
    return table(("parameter", "value", "unit", "status"), rows, css="params",
                 caption=f"{_chain_label(step.effects)} ({title}): RMS {step.rmse_ppm:.1f} ppm")


# -- position error ------------------------------------------------------------------------------
def _ts_top_step(heated: HeatedErrors) -> tuple[float, float, float]:
    """(largest rise K, TS min, TS max in ppm FS/K) over the readings of the top temperature step."""
    top = heated.rise_k >= TOP_STEP_SHARE * float(np.max(heated.rise_k))
    ts = temperature_stability_ppm_fs_per_k(heated.errors.error_m[top], heated.errors.fs_m, heated.rise_k[top])
    return float(np.max(heated.rise_k)), float(np.min(ts)), float(np.max(ts))


#: The paper's figure to compare each case with (Table 1 and Section 5).
PAPER_TS = {"target heated": "−11 … 18", "coil heated, Eq. (4)": "< 22 (500 Hz)",
            "coil heated, uncompensated": "—"}


def _ts_rows(group: TargetGroup, with_coil: bool) -> list[tuple[str, ...]]:
    """One row per case and frequency: largest rise, then max |e_pos| and TS for each calibration."""
    rows = []
    for freq, cases in group.cases.items():
        picks = [("target heated", lambda c: c.target_heated)]
        if with_coil:
            picks += [("coil heated, uncompensated", lambda c: c.coil_uncompensated),
                      ("coil heated, Eq. (4)", lambda c: c.coil_compensated)]
        for what, pick in picks:
            found = [(case, pick(case)) for case in cases if pick(case) is not None]
            if not found:
                continue
            cells = [lines([what, f"{group.material} target, {freq:g} Hz"]), f"{_ts_top_step(found[0][1])[0]:.0f} K"]
            for case, heated in found:
                _, low, high = _ts_top_step(heated)
                fs = float(np.max(np.abs(heated.errors.error_fs_percent)))
                cells.append(Html(f"n = {case.calibration.n_points}: {heated.errors.max_abs_mm():.3g} mm "
                                  f"({fs:.2g} % FS)<br>TS {low:+.0f} … {high:+.0f}"))
            rows.append(tuple([*cells, PAPER_TS[what]]))
    return rows


def position_section(findings: Findings) -> Parts:
    if isinstance(findings.groups, Omitted):
        return [note(findings.groups.reason)]
    groups = findings.groups
    parts: Parts = []
    with_cases = [g for g in groups if g.cases]
    skipped: Parts = [note(reason) for g in groups for reason in g.skipped.values()]
    if not with_cases:
        return list(skipped) or [note("no calibration: no room-temperature sweep with five or more positions "
                                      "at one frequency")]
    parts.append(paragraph("Each frequency is calibrated on its room-temperature sweep (Eq. 5) with all positions "
                           "and with the paper's n = 4 points in the sensitive near range; the heated readings are "
                           "then turned into positions and compared with the slide's."))
    parts.extend(skipped)
    target_panels = [(g.material, f, cases) for g in with_cases for f, cases in g.cases.items()
                     if any(c.target_heated is not None for c in cases)]
    if target_panels:
        parts.append(Plot(ft.target_heating_errors, (target_panels,),
                            "Position error of the readings with the target heated and the coil at room "
                            "temperature (like the paper's Fig. 14 and 22), mean per position and temperature step; "
                            "solid: calibrated with all positions, dashed: with n = 4."))
    else:
        parts.append(note("no target-heating position error: no readings with the target heated "
                          "(more than 5 K above room) and the coil at room temperature"))
    main = with_cases[0]
    coil_panels = [(f, cases) for f, cases in main.cases.items() if any(c.coil_compensated for c in cases)]
    if coil_panels:
        how = ("built the paper's way (Section 5) from the room-temperature sweep scaled by the coil-in-air "
               "inductance at each steady coil temperature" if main.coil_from_air
               else "measured with the coil heated and the target present")
        parts.append(Plot(ft.coil_heating_errors, (coil_panels,),
                            f"Position error of coil-heated readings ({how}), without (left) and with (right) the "
                            f"Eq. (4) temperature compensation (like the paper's Fig. 20 and 23); {main.material} "
                            "target; solid: all positions, dashed: n = 4."))
    else:
        parts.append(note("no coil-heating position error: no readings with the coil heated and the target "
                          "present, and no coil-in-air heating run to build them from"))
    rows = [row for group in with_cases for row in _ts_rows(group, group is main)]
    if rows:
        ours = table(("case", "Δϑ max", "calibrated on all positions", "on n = 4", "paper"), rows,
                     caption="These data: max |e_pos| and TS = e_pos / (FS · Δϑ) in ppm FS/K over the readings "
                             "of the highest temperature step", css="ts")
        paper = table(("sensor", "range", "temperature", "TS (ppm FS/K)"), PAPER_TABLE_1,
                      caption="The paper's Table 1: commercial sensors and the paper's demonstrator", css="ts")
        parts.append(side_by_side(ours, paper))
    return parts


# -- coil heating --------------------------------------------------------------------------------
def heating_section(findings: Findings) -> Parts:
    heating = findings.heating
    if isinstance(heating, Omitted):
        return [note(heating.reason)]
    assert isinstance(heating, CoilHeating)
    comp = heating.compensation
    fit = comp.fit
    parts: Parts = [Plot(ft.coil_heating, (heating.data, comp),
                    "Change of the coil-in-air inductance with coil temperature (like the paper's Fig. 17 at "
                    "15 kHz and Fig. 19 at 500 Hz) with the fit of Eq. (4), L_coil = L0 (1 + α Δϑ + β Δϑ²); "
                    "red: heating ramps, blue: cooling, black: steady. Below: what Eq. (4) leaves (ppm).")]
    rows = [("L0", value_error(fit.values["L0"], fit.stderr.get("L0"), 1e3, "mH")),
            ("α", value_error(fit.values["alpha"], fit.stderr.get("alpha"), 1e6, "ppm/K")),
            ("β", value_error(fit.values["beta"], fit.stderr.get("beta"), 1e6, "ppm/K²"))]
    if not fit.parameter("C_p").fixed:
        rows.append(("C_p", value_error(fit.values["C_p"], fit.stderr.get("C_p"), 1e12, "pF")))
    rows.append(("residual RMS", f"{fit.rms_ppm:.1f} ppm of L"
                 + f" (noise {fit.noise.ppm:.1f} ppm, from {fit.noise.source})"))
    rows.append(("readings", f"{fit.n}, coil {np.min(heating.data.t_coil_c):.0f} … "
                             f"{np.max(heating.data.t_coil_c):.0f} °C"))
    expansion = fit.model.sensor.former_expansion_per_k
    parts.append(table(("Eq. (4)", "value"), rows,
                       caption=f"Fit of Eq. (4) to the coil in air (reference {comp.reference_c:g} °C); the former's "
                               f"expansion alone ({fit.model.sensor.former}, {expansion * 1e6:g} ppm/K, ΔL ∝ area) "
                               f"gives α ≈ {2 * expansion * 1e6:g} ppm/K", css="params"))
    return parts


# -- spectroscopy --------------------------------------------------------------------------------
def spectroscopy_section(findings: Findings) -> Parts:
    spectra = findings.spectra
    if isinstance(spectra, Omitted):
        return [note(spectra.reason)]
    parts: Parts = [Plot(ft.spectra, ([(s.data, s.fit) for s in spectra],),
                    "Impedance of the coil in air against frequency at each coil temperature (like the paper's "
                    "Fig. 18): readings (markers) and the fitted parallel RLC circuit, (R_s + jωL) ‖ C ‖ R_p "
                    "(dashed).")]
    rows = [(s.source, f"{s.fit.t_coil_c:.0f} °C", value_error(s.fit.inductance_h, s.fit.stderr["inductance_h"], 1e3),
             value_error(s.fit.capacitance_f, s.fit.stderr["capacitance_f"], 1e12),
             value_error(s.fit.parallel_resistance_ohm, s.fit.stderr["parallel_resistance_ohm"], 1e-3),
             f"{s.fit.series_resistance_ohm:.1f}", f"{s.fit.resonance_hz / 1e3:.1f}", f"{s.fit.rms_ppm:.0f}")
            for s in spectra]
    ours = table(("file", "ϑ_coil", "L_p (mH)", "C_p (pF)", "R_p (kΩ)", "R_s (Ω)", "f_res (kHz)", "RMS (ppm |Z|)"),
                 rows, caption="These data: parallel RLC fits", css="ts")
    paper = table(("ϑ_coil", "L_p (mH)", "C_p (pF)", "R_p (kΩ)"), PAPER_TABLE_2,
                  caption="The paper's Table 2 (moist fired-clay former)", css="ts")
    parts.append(side_by_side(ours, paper))
    return parts


#: (anchor, title, builder) of every section, in report order.
SECTIONS: tuple[tuple[str, str, Callable[[Findings], Parts]], ...] = (
    ("runs", "Runs and files", runs_section),
    ("fit", "Inductance against distance and the model fit", fit_section),
    ("residuals", "Residual maps", residual_section),
    (DIAGNOSIS, "Diagnosis", diagnosis_section),
    ("position", "Position error and temperature stability", position_section),
    ("heating", "Coil heating characterisation", heating_section),
    ("spectroscopy", "Impedance spectroscopy", spectroscopy_section),
    ("paper", "The paper, reproduced", paper_comparison_section),
)
