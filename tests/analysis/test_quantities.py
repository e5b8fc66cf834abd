"""One way to show a number: SI prefixes, parameter status, position errors that know their limits."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from ecds_lab.analysis.quantities import (
    AT_BOUND,
    FITTED,
    FIXED,
    MODEL_FAILS,
    OUT_OF_RANGE,
    UNDETERMINED,
    VALID,
    format_quantity,
    parameter_status,
    position_error_figure,
)
from ecds_lab.model.parameters import Parameter


@pytest.mark.parametrize(("value", "unit", "stderr", "shown"), [
    (1.814e-11, "F", 5.0e-13, "18.14 ± 0.50 pF"),
    (0.053652, "H", 1.8e-5, "53.652 ± 0.018 mH"),
    (-8.27e-5, "1/K", 1.24e-5, "-83 ± 12 ppm/K"),
    (0.005044, "m", 2.5e-5, "5.044 ± 0.025 mm"),
    (984000.0, "Ohm", None, "984 kΩ"),
    (-2.0, "1", None, "-2"),
    (4.976e-6, "S", 7.3e-7, "4.98 ± 0.73 µS"),
])
def test_values_take_an_si_prefix_and_the_digits_their_error_allows(value, unit, stderr, shown):
    assert format_quantity(value, unit, stderr) == shown


def test_no_value_is_printed_as_a_long_decimal_or_with_a_bare_unit_one():
    for value in (1.814e-11, 4.9e-6, 2.5e-7, -2.0):
        text = format_quantity(value, "F" if value < 1e-9 else "1")
        assert "0.0000" not in text and not text.endswith(" 1")
    assert format_quantity(math.nan, "m") == "—"


def _fit(parameter: Parameter, stderr: float, fixed: dict[str, str] | None = None) -> SimpleNamespace:
    return SimpleNamespace(parameter=lambda name: parameter, stderr={parameter.name: stderr}, fixed=fixed or {})


def test_a_parameter_on_its_bound_or_undetermined_is_not_called_fitted():
    p3 = Parameter("p3", 5.0, 0.2, 5.0, "1", prior_scale=0.01)
    assert parameter_status(_fit(p3, 190.0), "p3").label == AT_BOUND
    p1 = Parameter("p1", -1e-3, -0.05, 0.05, "m", prior_scale=1e-3)
    assert parameter_status(_fit(p1, 0.36), "p1").label == UNDETERMINED
    assert parameter_status(_fit(p1, math.inf), "p1").label == UNDETERMINED
    assert parameter_status(_fit(p1, 1e-5), "p1").label == FITTED
    # an offset near zero known to a tenth of its plausible change is determined, not undetermined
    near_zero = Parameter("p1", -0.089e-3, -0.05, 0.05, "m", prior_scale=1e-3)
    assert parameter_status(_fit(near_zero, 0.099e-3), "p1").label == FITTED
    held = Parameter("R_p", 984e3, 0.0, math.inf, "Ohm", fixed=True)
    status = parameter_status(_fit(held, math.nan, {"R_p": "fixed from the sensor description"}), "R_p")
    assert status.label == FIXED and status.text() == "fixed (fixed from the sensor description)"


def test_a_position_error_outside_the_range_or_from_a_failing_model_is_no_length():
    errors = np.array([0.02, -0.03, 70.0, 80.0])
    figure = position_error_figure(errors, 80.0, out_of_range=np.array([False, False, True, False]))
    assert figure.status == VALID and figure.max_abs_mm == pytest.approx(0.03) and figure.n_out_of_range == 2
    assert "2 of 4 readings out of range" in figure.text()
    none_in_range = position_error_figure(errors, 80.0, out_of_range=np.ones(4, bool))
    assert none_in_range.status == OUT_OF_RANGE and none_in_range.max_abs_mm is None
    assert none_in_range.text().startswith("out of range") and "mm" not in none_in_range.text()
    failing = position_error_figure([19723.0], 80.0, model_rms_ppm=7489.0, noise_ppm=27.7)
    assert failing.status == MODEL_FAILS and failing.max_abs_mm is None and failing.to_json()["max_abs_mm"] is None
    assert "270x" in failing.text()


def test_an_error_larger_than_the_value_sets_the_prefix_and_rounds_both():
    assert format_quantity(-0.958e-3, "m", 3.344e-3) == "-1.0 ± 3.3 mm"
    assert format_quantity(5.0, "1", 189.6) == "5 ± 190"
    assert format_quantity(-1e-4, "m", 0.36) == "0 ± 360 mm"


def test_parameter_text_says_value_error_unit_and_a_status_other_than_fitted():
    from ecds_lab.analysis.quantities import parameter_text

    dc = Parameter("moist_dC", 1.814e-11, 0.0, 1e-9, "F", prior_scale=5e-12)
    assert parameter_text(_fit(dc, 5.0e-13), "moist_dC") == "moist_dC = 18.14 ± 0.50 pF"
    tau = Parameter("tau_x_20mm", -2.0, -2.0, 2.0, "1", prior_scale=0.1)
    text = parameter_text(_fit(tau, 0.3), "tau_x_20mm")
    assert text.startswith("tau_x_20mm = -2.00 ± 0.30 (at bound: on its lower bound -2") and " 1 " not in text


def test_a_failing_model_is_described_without_exponents():
    from ecds_lab.analysis.quantities import model_fails

    assert model_fails(15450.5, 161.49) == "the model leaves 15450 ppm, 96x the 161 ppm noise"
    assert model_fails(300.0, 31.9) == ""


def test_an_error_spanning_the_whole_allowed_range_is_no_plus_minus():
    """A drying's sorption width on its lower bound with no bound water to show it had a standard error of 3.5e15 K
    and was printed as ``1 ± 3500000000000000 K``: a number that says nothing. Where one standard error either side
    covers the whole allowed range the value is shown alone and the status says the data leave it anywhere there."""
    from ecds_lab.analysis.quantities import parameter_rows, parameter_text

    width = Parameter("sorption_width", 1.0, 1.0, 100.0, "K", prior_scale=5.0)
    text = parameter_text(_fit(width, 3.461e15), "sorption_width")
    assert text == ("sorption_width = 1 K (at bound: on its lower bound 1 K; the data leave it anywhere in its "
                    "allowed range 1 K to 100 K)")
    onset = Parameter("drying_onset", 143.0, 20.0, 200.0, "C", prior_scale=10.0)
    status = parameter_status(_fit(onset, 600.0), "drying_onset")
    assert status.label == UNDETERMINED and "anywhere in its allowed range 20 °C to 200 °C" in status.reason
    # a parameter near the top of a narrow range, its error half the range, was called fitted (half its value)
    assert parameter_status(_fit(replace(onset, value=190.0), 91.0), "drying_onset").label == UNDETERMINED
    # an error well inside the range keeps its ±, and an unbounded parameter always does
    assert parameter_text(_fit(onset, 6.0), "drying_onset") == "drying_onset = 143.0 ± 6.0 °C"
    free = Parameter("L0", 0.05, 0.0, math.inf, "H", prior_scale=1e-3)
    (row,) = parameter_rows(SimpleNamespace(parameters=[free], stderr={"L0": 1.0}, fixed={},
                                            parameter=lambda name: free))
    assert row["shown"] == "0.1 ± 1.0 H" and row["stderr"] == 1.0


def test_a_rate_of_a_prefixable_unit_takes_the_prefix():
    """A bending of 0.83 um/K read ``0.000000832 ± 0.000000056 m/K``."""
    assert format_quantity(8.32e-7, "m/K", 5.6e-8) == "832 ± 56 nm/K"
    assert format_quantity(-5.9e-10, "m/K^2", 4.5e-10) == "-590 ± 450 pm/K²"
    assert format_quantity(0.026, "1/s", 0.023) == "0.026 ± 0.023 1/s"
