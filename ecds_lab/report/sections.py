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

from ecds_lab.analysis.associations import BEYOND_CHANCE, NONE_BEYOND_CHANCE, Association
from ecds_lab.analysis.quantities import (
    MODEL_FAILS,
    MODEL_FAILS_FACTOR,
    PositionErrorFigure,
    chain_position_error,
    format_quantity,
    model_fails,
    parameter_rows,
)
from ecds_lab.analysis.subsample import random_rows
from ecds_lab.analysis.summary import (
    CALIBRATIONS_FROM_FIT,
    CalibrationCase,
    HeatedErrors,
    heated_figure,
    quantity_key,
    temperature_stability_top_step,
    ts_key,
)
from ecds_lab.analysis.suspect_units import unit_notes
from ecds_lab.data.measurements import Measurements
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
    quantity_span,
    side_by_side,
    table,
    value_error,
)
from ecds_lab.report.markup import (
    text as html_text,
)
from ecds_lab.report.paper_section import paper_comparison_section
from ecds_lab.report.render import Plot

#: How each Eq. (4) is labelled where it is shown.
STEADY_EQ4_LABEL = "quadratic through the steady in-air points at this frequency (the paper's procedure)"
JOINT_EQ4_LABEL = "joint model fit of every in-air reading at every frequency"

#: Residual plots of the diagnosis' chain show at most this many readings (drawn at random).
MAX_STEP_POINTS = 20_000
#: The residual maps show at most this many readings (drawn at random): a panel two inches wide cannot show more
#: than a few thousand points apart (the five map rows of 10^5 readings drew in 5.8 s of CPU, of 20,000 in 2.1 s).
MAX_MAP_POINTS = 20_000

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
    checks = [f"{item.name}: {text}" for item in findings.inputs for text in unit_notes(item.data, item.sensor)]
    if checks:
        parts.append(paragraph("Units to check before reading the figures below: " + "; ".join(checks) + ".",
                               "explanation"))
    return parts


# -- model fit -----------------------------------------------------------------------------------
def _param_rows(fit: Any) -> list[tuple[str, str, str]]:
    """One row per parameter of a fit: name, value ± error with its unit, and its status (``quantities``):
    fitted, at bound, undetermined, or fixed with the reason."""
    return [(row["name"], row["shown"], row["status"] + (f" ({row['status_reason']})" if "status_reason" in row
                                                         else "")) for row in parameter_rows(fit)]


def _params_table(group: TargetGroup) -> Html:
    fit = group.fit
    rows = _param_rows(fit)
    noise = f", noise {fit.noise.ppm:.1f} ppm (from {fit.noise.source})"
    failure = model_fails(fit.rms_ppm, fit.noise.ppm)
    verdict = f"; {MODEL_FAILS}: {failure}, so {CALIBRATIONS_FROM_FIT}" if failure else ""
    caption = (f"{group.material} target: baseline fit of {fit.n} readings, residual RMS {fit.rms_ppm:.1f} ppm of L"
               f"{noise}{verdict}")
    return table(("parameter", "value", "status"), rows, caption=caption, css="params")


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
    # the fit and its RMS are of every reading; the scatter shows a random share
    data, (residuals,), shown = _shown_at_random(main.data, [np.asarray(fit.residuals_ppm)], MAX_MAP_POINTS)
    caption += shown
    rows = fm.MAP_AXES
    return [Plot(fm.residual_map_row, (data, residuals, fit.noise_ppm, name, i == 0),
                 caption if i == len(rows) - 1 else "") for i, name in enumerate(rows)]


# -- diagnosis -----------------------------------------------------------------------------------
def diagnosis_section(findings: Findings) -> Parts:
    diagnosis = findings.diagnosis
    if isinstance(diagnosis, Omitted):
        return [note(diagnosis.reason), *_other_diagnoses(findings)]
    main = findings.main
    verdict = str(diagnosis.verdict)
    parts: Parts = [Html(f'<p>{badge(verdict.replace("_", " "), "good" if verdict == "adequate" else "bad")} '
                  f"noise {diagnosis.noise_ppm:.1f} ppm ({diagnosis.noise.source}), baseline residual "
                  f"{diagnosis.baseline.rms_ppm:.1f} ppm of L ({main.material if main else ''} target data"
                  f"{_glitches_note(diagnosis, main)})</p>"),
             paragraph(diagnosis.explanation, "explanation")]
    steps = list(getattr(diagnosis, "steps", []))
    if steps:
        parts.append(_chain_table(steps, diagnosis.noise_ppm))
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
        associations = _associations_table(diagnosis.associations, "Where the final model's residual lives (share "
                                                                    "of it each variable explains)")
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
    parts.extend(_other_diagnoses(findings))
    return parts


def _other_diagnoses(findings: Findings) -> Parts:
    """Every target group after the main one, diagnosed like it: verdict, explanation and the chain
    (a target whose model fails, e.g. steel far above the noise, is diagnosed, not left without a word)."""
    groups = {g.material: g for g in findings.groups} if isinstance(findings.groups, list) else {}
    parts: Parts = []
    for material, diagnosis in findings.others.items():
        group = groups.get(material)
        if isinstance(diagnosis, Omitted) or group is None:
            parts.append(note(f"{material} target not diagnosed: "
                              + (diagnosis.reason if isinstance(diagnosis, Omitted) else "no readings")))
            continue
        verdict = str(diagnosis.verdict)
        failure = model_fails(diagnosis.final.rmse_ppm, diagnosis.noise_ppm)  # the figures of this very line
        parts.append(Html(f'<h3>The {html_text(material)} target</h3><p>'
                          f'{badge(verdict.replace("_", " "), "good" if verdict == "adequate" else "bad")} '
                          f"noise {diagnosis.noise_ppm:.1f} ppm ({diagnosis.noise.source}), baseline residual "
                          f"{diagnosis.baseline.rms_ppm:.1f} ppm of L"
                          + (f" ({_glitches_note(diagnosis, group).lstrip('; ')})" if diagnosis.outliers else "")
                          + (f"; {MODEL_FAILS}: {html_text(failure)}" if failure else "") + "</p>"))
        parts.append(paragraph(diagnosis.explanation, "explanation"))
        steps = list(getattr(diagnosis, "steps", []))
        if steps:
            parts.append(_chain_table(steps, diagnosis.noise_ppm))
        if diagnosis.associations:
            parts.append(_associations_table(diagnosis.associations, f"Where the {material} target's final residual "
                                                                     "lives"))
    return parts


def _associations_table(associations: Sequence[Association], caption: str) -> Html:
    """Where the residual lives, with how far beyond chance each variable's share is; where none is (beyond
    BEYOND_CHANCE standard deviations), the caption says the residual is noise, so no share reads as a finding."""
    if not any(a.significance > BEYOND_CHANCE for a in associations):
        caption += f" ({NONE_BEYOND_CHANCE})"
    return table(("variable", "score", "beyond chance (sd)", "detail"),
                 [(a.variable, f"{a.score:.2f}", f"{a.significance:+.1f}", a.detail) for a in associations],
                 caption=caption)


def _glitches_note(diagnosis: Any, group: TargetGroup | None) -> str:
    """Why the diagnosis' baseline residual differs from the model-fit section's fit of the same readings:
    the glitch readings the diagnosis leaves out (that fit takes every reading)."""
    outliers = getattr(diagnosis, "outliers", None)
    if not outliers or group is None:
        return ""
    return (f"; {len(outliers)} glitch reading(s) left out: the model fit section's baseline fit, which "
            f"takes every reading, leaves {group.fit.rms_ppm:.1f} ppm with them")


def _chain_label(effects: Sequence[str]) -> str:
    return " + ".join(["baseline", *effects])


def step_error(step: Any, noise_ppm: float) -> PositionErrorFigure:
    """The RMS position error of one model of the chain, or why it is no length: the step's own figure
    (``Step.position_error``, the one the diagnosis JSON and text show), over the readings with a position
    (a coil-in-air reading has none; it is not a reading out of range)."""
    return chain_position_error(step.residual_mm, step.full_scale_mm, step.rmse_ppm, noise_ppm)


#: Where a chain's readings have no position (the coil in air only), there is no position error to show.
NO_POSITIONS = "none (no reading has a position: the coil in air)"


def _step_error_text(step: Any, noise_ppm: float) -> str:
    figure = step_error(step, noise_ppm)
    if not figure.n:
        return NO_POSITIONS
    return figure.text("rms") if figure.valid else figure.status


def _chain_table(steps: Sequence[Any], noise_ppm: float) -> Html:
    """The chain baseline → +effect → …: RMS, position error (RMS, % FS; or why none) and BIC of every model."""
    rows = []
    for s in steps:
        figure = step_error(s, noise_ppm)
        error = (number(figure.rms_mm, 3), number(figure.fs_percent(figure.rms_mm), 3)) if figure.valid else (
            (NO_POSITIONS if not figure.n else f"{figure.status} ({figure.reason})"), "—")
        rows.append((_chain_label(s.effects) + _tie_note(s), number(s.rmse_ppm, 4), *error, f"{s.fit.bic:.1f}"))
    return table(("model", "RMS (ppm of L)", "position error RMS (mm)", "position error (% FS)", "BIC"), rows,
                 caption="Watch the error fall: each step adds the effect the diagnosis claimed, one that stands "
                         "for a group the data cannot tell apart, or one that took only part of a residual outside "
                         "the library (these two not claimed); a model that leaves "
                         f"more than {MODEL_FAILS_FACTOR:g}x the noise gives no position error", css="chain")


def _tie_note(step: Any) -> str:
    """For a step whose effect is not claimed: the tied group it stands for, the structure it leaves where it
    acts (a part of a residual outside the library), or what it keeps beside a drift in time; for one claimed
    beside a smooth that took a residual outside the library, the variables of that smooth (its fall of the RMS is
    small beside that residual)."""
    group = getattr(step, "stands_for", None)
    if group:
        return f" (stands for {' / '.join(group)}: not claimed)"
    left = getattr(step, "leaves_structure", None)
    if left is not None:
        return f" (only part of a residual outside the library: {left:.0f} sd left where it acts; not claimed)"
    kept = getattr(step, "part_of_drift", None)
    if kept is not None:
        return f" (may be part of a drift in time: keeps {100 * max(kept, 0.0):.0f} % of its gain beside one; " \
            "not claimed)"
    beside = getattr(step, "beside", None)
    return f" (claimed beside a smooth in {', '.join(beside)} that takes the residual outside the library)" \
        if beside else ""


def _step_plot(diagnosis: Any, before: Any, after: Any) -> Html | Plot:
    """Residuals of one step of the chain and of the next, against the most telling variables."""
    data = diagnosis.data
    r0, r1 = np.asarray(before.fit.residuals_ppm), np.asarray(after.fit.residuals_ppm)
    if not (len(data) == len(r0) == len(r1)):
        return note("no residual plot for this step: the residuals do not match the readings row by row")
    added = after.effects[-1]
    telling = [a.variable for a in diagnosis.associations if a.variable in fm.VARIABLES]
    variables = fm.signature_variables(data, r0, r1, telling)
    noise = diagnosis.noise_ppm
    caption = (f"{_chain_label(before.effects)} (red) → + {added} (blue): RMS {before.rmse_ppm:.1f} → "
               f"{after.rmse_ppm:.1f} ppm, position error RMS {_step_error_text(before, noise)} → "
               f"{_step_error_text(after, noise)}. First panel: {fm.VARIABLES[variables[0]].label}, where the "
               f"residual changes most when {added} is added.")
    # a scatter of every reading of a huge campaign only costs time
    data, (r0, r1), shown = _shown_at_random(data, [r0, r1], MAX_STEP_POINTS)
    caption += shown
    return Plot(fm.before_after, (data, r0, r1, added, variables, diagnosis.noise_ppm, _chain_label(before.effects)),
                caption)


def _shown_at_random(data: Measurements, arrays: list[np.ndarray], limit: int
                     ) -> tuple[Measurements, list[np.ndarray], str]:
    """At most ``limit`` readings for a scatter (and the same rows of ``arrays``), drawn at random
    (``subsample.random_rows``), with the caption's note saying so ('' when every reading is shown)."""
    if len(data) <= limit:
        return data, arrays, ""
    rows = random_rows(len(data), limit)
    return (data.select(rows), [a[rows] for a in arrays],
            f" {limit:,} of the {len(data):,} readings shown, at random.")


def _step_params(step: Any, title: str) -> Html:
    """The parameter table of one model of the chain."""
    fit = step.fit
    rows = _param_rows(fit)
    return table(("parameter", "value", "status"), rows, css="params",
                 caption=f"{_chain_label(step.effects)} ({title}): RMS {step.rmse_ppm:.1f} ppm")


# -- position error ------------------------------------------------------------------------------
#: The paper's figure to compare each case with (Table 1 and Section 5).
PAPER_TS = {"target_heated": "−11 … 18", "coil_compensated": "< 22 (500 Hz)", "coil_uncompensated": "—"}


def _case_name(kind: str, case: CalibrationCase) -> str:
    if kind == "target_heated":
        return "target heated"
    if kind == "coil_uncompensated":
        return "coil heated, uncompensated"
    return f"coil heated, compensated ({case.compensation_method})"


def _ts_rows(group: TargetGroup, with_coil: bool) -> list[tuple[object, ...]]:
    """One row per case and frequency: largest rise, then max |e_pos| and TS for each calibration.

    Each figure is ``summary.heated_figure``'s, the one ``ecds-lab fit`` prints (same key), so a figure
    out of range or from a failing model reads so here too."""
    rows: list[tuple[object, ...]] = []
    for freq, cases in group.cases.items():
        room = [f"n = {c.calibration.n_points}: "
                + quantity_span(quantity_key("room", group.material, freq, c.label),
                                (figure := _figure_of(c.room, c)).max_abs_mm, text_shown=figure.text())
                for c in cases]
        rows.append((lines(["room temperature (the calibration's own error)", f"{group.material} target, {freq:g} Hz"]),
                     "—", *(Html(r) for r in room), "—"))
        kinds = ["target_heated"] + (["coil_uncompensated", "coil_compensated"] if with_coil else [])
        for kind in kinds:
            found = [(case, getattr(case, kind)) for case in cases if getattr(case, kind) is not None]
            if not found:
                continue
            cells: list[object] = [lines([_case_name(kind, found[0][0]), f"{group.material} target, {freq:g} Hz"]),
                                   f"{float(np.max(found[0][1].rise_k)):.0f} K"]
            for case, heated in found:
                figure = heated_figure(heated, case.calibration, case.noise_ppm)
                key = quantity_key(kind, group.material, freq, case.label)
                shown = quantity_span(key, figure.max_abs_mm, text_shown=figure.text())
                top = temperature_stability_top_step(heated.errors, heated.rise_k) if figure.valid else None
                ts = (f"<br>TS {quantity_span(ts_key(key, 'min'), top[0], text_shown=f'{top[0]:+.0f}')} … "
                      f"{quantity_span(ts_key(key, 'max'), top[1], text_shown=f'{top[1]:+.0f}')}"
                      if top is not None else "")
                cells.append(Html(f"n = {case.calibration.n_points}: {shown}{ts}"))
            rows.append(tuple([*cells, PAPER_TS[kind]]))
    return rows


def _figure_of(errors: Any, case: CalibrationCase) -> PositionErrorFigure:
    """The figure of room-temperature readings under their case's calibration (as ``ecds-lab fit`` shows it)."""
    return heated_figure(HeatedErrors(errors, np.zeros(len(errors.x_ref_m))), case.calibration, case.noise_ppm)


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
                           "and with the paper's n = 4 points in the sensitive near range: L0 and p1..p4 are fitted, "
                           "the other parameters held at the model fit's values above; the heated readings are "
                           "then turned into positions and compared with the slide's. A calibration whose own "
                           f"residual exceeds {MODEL_FAILS_FACTOR:g}x the noise gives no position error (\"model fails "
                           "here\")."))
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
        fs = sorted({f"{c.calibration.fs_m * 1e3:.4g} mm" for g in with_cases for cs in g.cases.values() for c in cs})
        ours = table(("case", "Δϑ max", "calibrated on all positions", "on n = 4", "paper"), rows,
                     caption="These data, by calibration inversion (Eq. 5-6, the paper's Section 5): max |e_pos| over "
                             "the readings inside the calibrated range, and TS = e_pos / (FS · Δϑ) in ppm FS/K over "
                             f"those of the highest temperature step; FS = {', '.join(fs)}, the calibrated span. "
                             "The first row of each frequency is the calibration's own error at room temperature, "
                             "which the inversion carries into every heated figure. The paper comparison below quotes "
                             "e_pos = ΔL / S (the paper's Section 3.3 and 4.3), which subtracts the room readings at "
                             "the same positions and so leaves that error out: a different method, labelled there.",
                     css="ts")
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
    expansion = fit.model.sensor.former_expansion_per_k
    parts: Parts = [Plot(ft.coil_heating, (heating.data, comp, heating.eq4),
                    "Change of the coil-in-air inductance with coil temperature (like the paper's Fig. 17 at "
                    "15 kHz and Fig. 19 at 500 Hz), L_coil = L0 (1 + α Δϑ + β Δϑ²) of Eq. (4) fitted two ways: "
                    "green, the joint model fit over every in-air reading at every frequency; purple dashed, the "
                    "paper's procedure, a quadratic per frequency through the steady points (squares). Red: heating "
                    "ramps, blue: cooling, black: steady. Below: what the joint fit leaves (ppm).")]
    rows: list[tuple[object, ...]] = []
    for freq, eq4 in sorted(heating.eq4.items()):
        rows.append((f"{freq:g} Hz", STEADY_EQ4_LABEL,
                     Html(quantity_span(f"eq4.alpha_per_k.{freq:g}Hz", eq4.alpha_per_k, "1/K")),
                     format_quantity(eq4.beta_per_k2, "1/K^2"), format_quantity(eq4.l0_h, "H"),
                     f"{len(eq4.t_coil_c)} steady temperatures over {eq4.span_k:.0f} K"
                     + (f"; {eq4.glitches_excluded} glitch reading(s) left out of the steady means"
                        if eq4.glitches_excluded else "")))
    failure = model_fails(fit.rms_ppm, fit.noise.ppm)
    joint = [format_quantity(fit.values[n], fit.parameter(n).unit, fit.stderr.get(n)) for n in ("alpha", "beta", "L0")]
    if failure:
        spread = ""
        if len(heating.eq4) > 1:
            spread = ("; one α cannot serve every frequency: the steady in-air points give "
                      + ", ".join(f"{format_quantity(e.alpha_per_k, '1/K')} at {f:g} Hz"
                                  for f, e in sorted(heating.eq4.items())))
        joint = [f"{MODEL_FAILS} ({failure}{spread})", "—", "—"]
    rows.append(("all", JOINT_EQ4_LABEL, *joint, f"{fit.n} readings, residual {fit.rms_ppm:.1f} ppm "
                 f"(noise {fit.noise.ppm:.1f} ppm, from {fit.noise.source})"))
    parts.append(table(("frequency", "method", "α", "β", "L0", "from"), rows,
                       caption=f"Eq. (4) of the coil in air (reference {comp.reference_c:g} °C). The paper fitted it "
                               "per frequency to the steady coil temperatures (first rows); the position errors of "
                               "this report and the paper comparison use those. The former's expansion alone "
                               f"({fit.model.sensor.former}, {format_quantity(expansion, '1/K')}, ΔL ∝ area) gives "
                               f"α ≈ {format_quantity(2 * expansion, '1/K')}"
                               f"{_expansion_note(heating.eq4, 2 * expansion)}.", css="params"))
    return parts


def _expansion_note(eq4: dict[float, Any], expected_per_k: float) -> str:
    """Where the measured α is far from the former's expansion alone, say so beside it, so the two figures do not
    stand side by side without a word."""
    far = {f: e.alpha_per_k for f, e in sorted(eq4.items())
           if abs(e.alpha_per_k - expected_per_k) > 0.5 * abs(expected_per_k)}
    if not far:
        return ""
    shown = ", ".join(f"{format_quantity(a, '1/K')} at {f:g} Hz" for f, a in far.items())
    return (f"; the steady points give {shown}: at {'these frequencies' if len(far) > 1 else 'this frequency'} "
            "the coil's inductance follows temperature otherwise than the former's expansion alone would make it; "
            "what else acts, these data alone do not separate")


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
