"""The CSV import reads in one vectorised pass and keeps the row-by-row reader's rules and messages."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ecds_lab.data import measurements
from ecds_lab.data.measurements import DataError, Measurements, approach_direction

HEADER = "time_s,x_mm,freq_hz,t_coil_c,t_target_c,ls_h,rs_ohm"


def sample(n: int = 50) -> Measurements:
    rng = np.random.default_rng(1)
    x = np.where(np.arange(n) % 7 == 0, np.inf, 20.0 + rng.integers(0, 10, n) * 2.5)
    return Measurements(time_s=np.arange(n) * 1.7, x_m=x * 1e-3, freq_hz=np.where(np.arange(n) % 2, 500.0, 15000.0),
                        t_coil_c=21.0 + rng.random(n), t_target_c=22.0 + rng.random(n),
                        ls_h=0.05 + 1e-4 * rng.random(n), rs_ohm=50.0 + rng.random(n))


@pytest.fixture
def row_by_row_forbidden(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail if the per-row reader runs (a well-formed file must not need it)."""
    def refuse(*_: object) -> None:
        raise AssertionError("the row-by-row reader ran")
    monkeypatch.setattr(measurements, "_csv_rows", refuse)


def test_round_trip_is_exact_without_python_per_row(tmp_path: Path, row_by_row_forbidden: None) -> None:
    data = sample()
    data.to_csv(tmp_path / "a.csv")
    back = Measurements.from_csv(tmp_path / "a.csv")
    for name in ("time_s", "freq_hz", "t_coil_c", "t_target_c", "ls_h", "rs_ohm"):
        np.testing.assert_array_equal(getattr(back, name), getattr(data, name))
    np.testing.assert_allclose(back.x_m, data.x_m, rtol=1e-12)
    assert np.isinf(back.x_m).sum() == np.isinf(data.x_m).sum()
    np.testing.assert_array_equal(back.direction, data.direction)


def test_columns_in_any_order_extra_columns_bom_crlf_blank_lines_quotes(tmp_path: Path,
                                                                        row_by_row_forbidden: None) -> None:
    text = ("\ufeffnote,rs_ohm,ls_h,t_target_c,t_coil_c,freq_hz,x_mm,time_s\r\n"
            '7,50.5,0.051,23.5,21.5,500,"20.5",1.0\r\n'
            "\r\n"
            "8,50.6,0.052,23.6,21.6,15000,inf,2.0\r\n")
    path = tmp_path / "b.csv"
    path.write_bytes(text.encode("utf-8"))
    data = Measurements.from_csv(path)
    np.testing.assert_array_equal(data.time_s, [1.0, 2.0])
    np.testing.assert_array_equal(data.x_m, [20.5e-3, math.inf])
    np.testing.assert_array_equal(data.freq_hz, [500.0, 15000.0])
    np.testing.assert_array_equal(data.rs_ohm, [50.5, 50.6])


@pytest.mark.parametrize(("row", "message"), [
    ("1.0,20,500,21,22,abc,50", "row 3, column ls_h: 'abc' is not a number"),
    ("1.0,20,500,nan,22,0.05,50", "row 3, column t_coil_c: 'nan' is not allowed"),
    ("1.0,20,500,21,inf,0.05,50", "row 3, column t_target_c: 'inf' is not allowed"),
    ("1.0,20,500,21,22,nan,50", "row 3, column ls_h: 'nan' is not allowed"),
    ("1.0,20,500", "row 3, column t_coil_c: '<missing>' is not a number"),
])
def test_a_bad_cell_is_named_by_row_and_column(tmp_path: Path, row: str, message: str) -> None:
    path = tmp_path / "c.csv"
    path.write_text(f"{HEADER}\n0.5,20,500,21,22,0.05,50\n{row}\n")
    with pytest.raises(DataError, match=message.replace("(", r"\(")):
        Measurements.from_csv(path)


def test_rows_of_empty_cells_are_skipped(tmp_path: Path) -> None:
    path = tmp_path / "d.csv"
    path.write_text(f"{HEADER}\n0.5,20,500,21,22,0.05,50\n,,,,,,\n1.5,21,500,21,22,0.05,50\n")
    np.testing.assert_array_equal(Measurements.from_csv(path).time_s, [0.5, 1.5])


def _direction_row_by_row(x_m: np.ndarray, segment: np.ndarray) -> np.ndarray:
    """The rule stated plainly: per segment, the sign of the last change of x among the rows with a distance."""
    direction = np.zeros(len(x_m), dtype=int)
    for seg in np.unique(segment):
        last_x, last_dir = math.nan, 0
        for i in np.flatnonzero(segment == seg):
            if not math.isfinite(x_m[i]):
                continue
            if math.isfinite(last_x) and x_m[i] != last_x:
                last_dir = 1 if x_m[i] > last_x else -1
            last_x, direction[i] = x_m[i], last_dir
    return measurements._fill_first_direction(direction, x_m, segment)


def test_vectorised_direction_follows_the_row_by_row_rule() -> None:
    rng = np.random.default_rng(5)
    for trial in range(300):
        n = int(rng.integers(0, 40))
        x = rng.choice([20.0, 21.0, 22.0, np.inf, 23.0], n)
        segment = np.sort(rng.integers(0, 3, n)) if trial % 2 else rng.integers(0, 3, n)
        np.testing.assert_array_equal(approach_direction(x, segment), _direction_row_by_row(x, segment))
