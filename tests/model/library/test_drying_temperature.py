"""parasitic_capacitance: its own course is shown where the former dries, not where the coil is hottest."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.library.parasitic_capacitance import ParasiticCapacitance

#: A drying with a threshold at 35 C, fast enough to leave the former dry within minutes of reaching 40 C.
FAST_AT_40_C = {"moist_dC": 15e-12, "moist_dG": 0.0, "drying_rate": 1e-2, "drying_onset": 35.0, "drying_width": 1.0,
                "drying_order": 1.0, "bound_share": 0.0, "sorption_width": 18.0}


def _coil_held(levels_c: tuple[float, ...], hold_s: float = 3600.0) -> Measurements:
    """The coil in air held at each of ``levels_c`` for ``hold_s``, a reading a minute (only the inputs matter)."""
    per_level = int(hold_s // 60)
    t_coil = np.repeat(np.asarray(levels_c, float), per_level)
    n = len(t_coil)
    return Measurements(time_s=np.arange(n) * 60.0, x_m=np.full(n, np.inf), freq_hz=np.full(n, 15000.0),
                        t_coil_c=t_coil, t_target_c=np.full(n, 22.0), ls_h=np.full(n, 0.05), rs_ohm=np.full(n, 20.0))


def test_the_drying_temperature_is_where_the_moisture_fell():
    data = _coil_held((22.0, 40.0, 80.0, 120.0))
    effect = ParasiticCapacitance(SensorConfig())
    assert effect.moisture(data, FAST_AT_40_C)[-1] < 1e-6  # dry long before the hottest hold
    assert effect.drying_temperature(data, FAST_AT_40_C) == pytest.approx(40.0, abs=1.0)


def test_the_signature_is_the_rate_there_and_its_gradient_is_that_of_the_rate():
    data = _coil_held((22.0, 40.0, 80.0, 120.0))
    effect = ParasiticCapacitance(SensorConfig())
    value, gradient = effect.signature(data, FAST_AT_40_C)
    at = effect.drying_temperature(data, FAST_AT_40_C)
    rate = lambda p: p["drying_rate"] / (1 + np.exp(-(at - p["drying_onset"]) / p["drying_width"]))  # noqa: E731
    assert value == pytest.approx(np.log(rate(FAST_AT_40_C)))
    for name, step in (("drying_rate", 1e-6), ("drying_onset", 1e-4), ("drying_width", 1e-5)):
        moved = {**FAST_AT_40_C, name: FAST_AT_40_C[name] + step}
        assert gradient[name] == pytest.approx((np.log(rate(moved)) - value) / step, rel=1e-3)


def test_a_former_that_hardly_dries_is_judged_where_the_coil_is_hottest():
    data = _coil_held((22.0, 40.0, 80.0))
    effect = ParasiticCapacitance(SensorConfig())
    slow = {**FAST_AT_40_C, "drying_rate": 1e-9}
    assert effect.drying_temperature(data, slow) == pytest.approx(80.0)
