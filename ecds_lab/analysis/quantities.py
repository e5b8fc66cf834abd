"""How a reported number is shown, one way for every output (CLI text, JSON, report).

Three jobs, each one function here so every output agrees:

- ``format_quantity``: a value (and its standard error) with an SI prefix or a ppm scale and
  sensible significant digits (``18.14 ± 0.50 pF``, not ``0.00000000001814 F``; ``-2``, not ``-2 1``).
- ``parameter_status``: a fitted parameter is *fitted*, *at bound*, *undetermined* (standard error
  comparable to the value and to its plausible change, or an unconstrained direction) or *fixed*
  (with the reason), never simply "fitted" when the data did not determine it; a standard error that
  spans the parameter's whole allowed range is not printed as a ± at all (``spans_its_range``).
- ``position_error_figure``: a position error that knows its limits: readings outside the calibrated
  range, or a model whose residual is far above the noise, give "out of range" / "model fails here",
  never a length.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

#: SI prefixes of engineering notation, smallest first.
_PREFIXES = ((1e-15, "f"), (1e-12, "p"), (1e-9, "n"), (1e-6, "µ"), (1e-3, "m"), (1.0, ""), (1e3, "k"),
             (1e6, "M"), (1e9, "G"))
#: Units that take an SI prefix, and the symbol each is shown with.
_PREFIXABLE = {"H": "H", "F": "F", "S": "S", "Ohm": "Ω", "Ω": "Ω", "m": "m", "s": "s", "Hz": "Hz", "V": "V",
               "A": "A", "W": "W"}
#: Temperature coefficients are shown in ppm: unit -> the ppm unit.
_PPM_UNITS = {"1/K": "ppm/K", "1/K^2": "ppm/K²", "1/K²": "ppm/K²"}
#: Units shown under another symbol ("1" is a pure number: no unit is shown).
_SYMBOLS = {"1": "", "C": "°C", "degC": "°C"}
#: Significant digits of a value shown without a standard error.
DIGITS = 4


def _scale_for(value: float, unit: str) -> tuple[float, str]:
    """(factor, shown unit) that puts ``value`` of ``unit`` between 1 and 1000 (engineering notation)."""
    if unit in _PPM_UNITS:
        return 1e6, _PPM_UNITS[unit]
    top, slash, bottom = unit.partition("/")
    if slash and top in _PREFIXABLE:  # a rate of a prefixable unit: the prefix on it (0.83 µm/K, not 0.00000083 m/K)
        factor, shown = _scale_for(value, top)
        return factor, f"{shown}/{bottom.replace('^2', '²')}"
    if unit not in _PREFIXABLE:
        return 1.0, _SYMBOLS.get(unit, unit)
    symbol = _PREFIXABLE[unit]
    size = abs(value)
    if not size > 0 or not math.isfinite(size):
        return 1.0, symbol
    chosen = _PREFIXES[0]
    for factor, prefix in _PREFIXES:
        if size >= factor * (1 - 1e-12):
            chosen = (factor, prefix)
    return 1.0 / chosen[0], chosen[1] + symbol


def _with_unit(text: str, unit: str) -> str:
    return f"{text} {unit}" if unit else text


def format_quantity(value: float | None, unit: str = "", stderr: float | None = None, digits: int = DIGITS,
                    keep_zeros: bool = False) -> str:
    """``value ± stderr unit`` with an SI prefix (or ppm for 1/K) and sensible digits; "—" when unknown.

    With a finite, positive standard error the error's two significant digits set the decimals
    (the value is shown to the same place); without one, ``digits`` significant digits, trailing
    zeros dropped unless ``keep_zeros`` (figures of merit compared side by side keep them).
    """
    if value is None or not math.isfinite(value):
        return "—"
    has_error = stderr is not None and math.isfinite(stderr) and stderr > 0
    reference = max(abs(value), float(stderr)) if has_error else value  # type: ignore[arg-type]
    factor, shown = _scale_for(reference, unit)
    v = value * factor
    if not has_error:
        return _with_unit(_significant(v, digits, keep_zeros), shown)
    e = float(stderr) * factor  # type: ignore[arg-type]
    decimals = 1 - math.floor(math.log10(e))
    if decimals < 0:  # an error of 100 or more: rounded to its two significant digits, the value to units
        e, decimals = round(e, decimals), 0
    value_text = f"{v:.{decimals}f}"
    if float(value_text) == 0:
        value_text = value_text.lstrip("-")
    return _with_unit(f"{value_text} ± {e:.{decimals}f}", shown)


def _significant(v: float, digits: int, keep_zeros: bool = False) -> str:
    """``v`` to ``digits`` significant digits (trailing zeros dropped unless kept), no exponent for everyday sizes."""
    if v == 0:
        return "0"
    if 1e-4 <= abs(v) < 1e7:
        decimals = max(0, digits - 1 - math.floor(math.log10(abs(v))))
        shown = f"{v:.{decimals}f}"
        return shown.rstrip("0").rstrip(".") if "." in shown and not keep_zeros else shown
    return f"{v:.{digits - 1}e}"


# -- parameters --------------------------------------------------------------------------------------
FITTED, AT_BOUND, UNDETERMINED, FIXED = "fitted", "at bound", "undetermined", "fixed"
#: A parameter is undetermined when its standard error exceeds this share of both its value and its
#: plausible change (the prior scale): the data leave it about as uncertain as it is large.
UNDETERMINED_SHARE = 0.5
#: A value within this share of its prior scale from a bound sits on that bound.
AT_BOUND_SHARE = 1e-3


@dataclass(frozen=True)
class ParameterStatus:
    """What a fit did with one parameter: ``label`` is fitted / at bound / undetermined / fixed."""

    label: str
    reason: str = ""

    def text(self) -> str:
        return f"{self.label} ({self.reason})" if self.reason else self.label

    def to_json(self) -> dict[str, str]:
        return {"status": self.label, **({"status_reason": self.reason} if self.reason else {})}


def spans_its_range(p: Any, stderr: float | None) -> bool:
    """Whether one standard error either side of the value covers the parameter's whole allowed range: the data
    leave it anywhere there, and a ``±`` would print a number that means nothing (a drying's sorption width
    ``1 ± 3500000000000000 K`` where no bound water shows it)."""
    span = p.upper - p.lower
    return stderr is not None and math.isfinite(span) and span > 0 and math.isfinite(stderr) and 2 * stderr >= span


def _anywhere_in(p: Any) -> str:
    return (f"the data leave it anywhere in its allowed range {format_quantity(p.lower, p.unit)} to "
            f"{format_quantity(p.upper, p.unit)}")


def parameter_status(fit: Any, name: str) -> ParameterStatus:
    """Fitted / at bound / undetermined / fixed (with the reason) for one parameter of a ``FitResult``."""
    p = fit.parameter(name)
    if p.fixed:
        return ParameterStatus(FIXED, fit.fixed.get(name, "held by the caller"))
    stderr = float(fit.stderr.get(name, math.nan))
    near = AT_BOUND_SHARE * p.prior_scale
    anywhere = spans_its_range(p, stderr)
    for bound, side in ((p.lower, "lower"), (p.upper, "upper")):
        if math.isfinite(bound) and abs(p.value - bound) <= near:
            error = (f"; {_anywhere_in(p)}" if anywhere else
                     f", ± {format_quantity(stderr, p.unit)}" if math.isfinite(stderr) else "")
            return ParameterStatus(AT_BOUND, f"on its {side} bound {format_quantity(bound, p.unit)}{error}")
    if not math.isfinite(stderr):
        return ParameterStatus(UNDETERMINED, "the data do not constrain it (flat direction)")
    if anywhere:
        return ParameterStatus(UNDETERMINED, _anywhere_in(p))
    if stderr >= UNDETERMINED_SHARE * max(abs(p.value), p.prior_scale):
        return ParameterStatus(UNDETERMINED, "standard error comparable to or larger than the value")
    return ParameterStatus(FITTED)


def shown_value(p: Any, stderr: float | None) -> str:
    """``value ± error unit`` of one parameter, or its value alone where the error spans its whole range."""
    return format_quantity(p.value, p.unit, None if spans_its_range(p, stderr) else stderr)


def parameter_rows(fit: Any) -> list[dict[str, Any]]:
    """Every parameter of a fit: name, SI value, stderr (None if fixed or unconstrained), unit, status, text."""
    rows = []
    for p in fit.parameters:
        stderr = None if p.fixed else fit.stderr.get(p.name)
        stderr = float(stderr) if stderr is not None and math.isfinite(stderr) else None
        status = parameter_status(fit, p.name)
        rows.append({"name": p.name, "value": p.value, "stderr": stderr, "unit": p.unit, **status.to_json(),
                     "shown": shown_value(p, stderr)})
    return rows


def params_json(fit: Any) -> dict[str, dict[str, Any]]:
    """name -> {value, stderr, unit, status, status_reason, shown}: a fit's parameters as every JSON output
    carries them (``parameter_rows`` keyed by name)."""
    return {row["name"]: {k: v for k, v in row.items() if k != "name"} for row in parameter_rows(fit)}


def parameter_text(fit: Any, name: str) -> str:
    """``name = value ± error unit`` and, unless fitted, its status: one parameter as every text output shows it
    (e.g. ``moist_dC = 18.14 ± 0.50 pF``, ``tau_x_20mm = -2.00 ± 0.30 (at bound: on its lower bound -2, ± 0.30)``,
    ``p3 = 5 (at bound: on its upper bound 5; the data leave it anywhere in its allowed range 0.2 to 5)``)."""
    p = fit.parameter(name)
    stderr = None if p.fixed else fit.stderr.get(name)
    status = parameter_status(fit, name)
    shown = f"{name} = {shown_value(p, stderr)}"
    if status.label == FITTED:
        return shown
    return f"{shown} ({status.label}: {status.reason})" if status.reason else f"{shown} ({status.label})"


# -- position errors ---------------------------------------------------------------------------------
VALID, OUT_OF_RANGE, MODEL_FAILS = "valid", "out of range", "model fails here"
#: A model whose residual RMS exceeds this multiple of the noise fails: its inverse gives no position.
MODEL_FAILS_FACTOR = 10.0


@dataclass(frozen=True)
class PositionErrorFigure:
    """Max and RMS position error over the readings the calibration can speak for, or why there is none."""

    status: str
    fs_mm: float
    n: int
    n_out_of_range: int = 0
    max_abs_mm: float | None = None
    rms_mm: float | None = None
    reason: str = ""

    @property
    def valid(self) -> bool:
        return self.status == VALID

    def fs_percent(self, value_mm: float | None) -> float | None:
        return None if value_mm is None or not self.fs_mm > 0 else 100.0 * value_mm / self.fs_mm

    def text(self, which: str = "max") -> str:
        """E.g. ``0.031 mm (0.039 % FS)``, ``out of range`` or ``model fails here (…)``."""
        if not self.valid:
            return f"{self.status} ({self.reason})" if self.reason else self.status
        value = self.max_abs_mm if which == "max" else self.rms_mm
        shown = (f"{format_quantity((value or 0.0) * 1e-3, 'm', digits=3, keep_zeros=True)} "
                 f"({self.fs_percent(value):.3g} % FS)")
        if self.n_out_of_range:
            shown += f"; {self.n_out_of_range} of {self.n} readings out of range, not counted"
        return shown

    def to_json(self) -> dict[str, Any]:
        return {"status": self.status, "n": self.n, "out_of_range": self.n_out_of_range,
                "max_abs_mm": self.max_abs_mm, "rms_mm": self.rms_mm,
                "max_abs_fs_percent": self.fs_percent(self.max_abs_mm), "fs_mm": self.fs_mm,
                **({"reason": self.reason} if self.reason else {})}


def model_fails(rms_ppm: float | None, noise_ppm: float | None) -> str:
    """Why a model's positions cannot be trusted ("" when they can): its residual far above the noise."""
    if rms_ppm is None or noise_ppm is None or not noise_ppm > 0 or not math.isfinite(rms_ppm):
        return ""
    ratio = rms_ppm / noise_ppm
    if ratio <= MODEL_FAILS_FACTOR:
        return ""
    return f"the model leaves {_significant(rms_ppm, 4)} ppm, {ratio:.0f}x the {_significant(noise_ppm, 3)} ppm noise"


def position_error_figure(error_mm: Sequence[float] | np.ndarray, fs_mm: float,
                          out_of_range: Sequence[bool] | np.ndarray | None = None, *,
                          model_rms_ppm: float | None = None, noise_ppm: float | None = None) -> PositionErrorFigure:
    """The position error of some readings, or the reason it is not a length.

    A reading is out of range when the inversion clamped it (``out_of_range``), its error is not
    finite, or its error reaches the full scale (no reading inside the calibrated range can be
    further off). The figure is "model fails here" when the model behind it leaves more than
    ``MODEL_FAILS_FACTOR`` times the noise, and "out of range" when no reading is in range.
    """
    e = np.asarray(error_mm, float)
    n = len(e)
    outside = ~np.isfinite(e) | (np.abs(np.nan_to_num(e, nan=np.inf)) >= fs_mm if fs_mm > 0 else False)
    if out_of_range is not None:
        outside |= np.asarray(out_of_range, bool)
    failure = model_fails(model_rms_ppm, noise_ppm)
    if failure:
        return PositionErrorFigure(MODEL_FAILS, fs_mm, n, int(outside.sum()), reason=failure)
    inside = e[~outside]
    if not len(inside):
        reason = f"all {n} readings outside the calibrated range" if n else "no readings"
        return PositionErrorFigure(OUT_OF_RANGE, fs_mm, n, int(outside.sum()), reason=reason)
    return PositionErrorFigure(VALID, fs_mm, n, int(outside.sum()), float(np.max(np.abs(inside))),
                               float(np.sqrt(np.mean(inside**2))))


def chain_position_error(residual_mm: np.ndarray, full_scale_mm: float, rmse_ppm: float,
                         noise_ppm: float | None) -> PositionErrorFigure:
    """The position error of one model of the chain over the readings with a position (a NaN residual: a coil-in-air
    reading, which has none and is no reading out of range); every output of a step shows this one figure."""
    residual = np.asarray(residual_mm, float)
    positioned = residual[~np.isnan(residual)]
    return position_error_figure(positioned, full_scale_mm, model_rms_ppm=rmse_ppm, noise_ppm=noise_ppm)


def full_scale_mm(x_mm: Sequence[float] | np.ndarray) -> float:
    """The full scale: the span of the calibrated positions (mm), the one FS every output quotes."""
    x = np.asarray(x_mm, float)
    x = x[np.isfinite(x)]
    return float(np.ptp(x)) if len(x) else 0.0
