"""target_tau_temperature: what the target's temperatures can tell is judged on the readings with the target under
the coil; readings in air (a hot target cooling while the coil is away) show nothing of tau_T."""

from __future__ import annotations

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.sensor_model import SensorModel


def _campaign(sweep_temperatures_c: tuple[float, ...], cooling_in_air: bool, hottest_c: float | None = None
              ) -> Measurements:
    """A sweep of nine positions at each target temperature, then (optionally) the target cooling from the last
    one (or ``hottest_c``) to room temperature with the coil in air (made-up readings: only the inputs matter)."""
    x = np.tile(np.linspace(0.02, 0.10, 9), len(sweep_temperatures_c))
    t = np.repeat(np.array(sweep_temperatures_c, float), 9)
    if cooling_in_air:
        x = np.concatenate([x, np.full(12, np.inf)])
        t = np.concatenate([t, np.linspace(hottest_c or sweep_temperatures_c[-1], 25.0, 12)])
    n = len(x)
    return Measurements(time_s=np.arange(n, dtype=float), x_m=x, freq_hz=np.full(n, 15000.0),
                        t_coil_c=np.full(n, 22.0), t_target_c=t, ls_h=np.full(n, 0.05), rs_ohm=np.full(n, 50.0))


def test_a_curvature_in_temperature_is_not_seen_through_readings_in_air():
    """A cold and a hot sweep: two temperatures under the coil, so the curvature stays fixed, though the target's
    cooling in air passes through every temperature between (validation study case 110: the free curvature went
    to its bound and made a conductivity change implausible beside its bending twin)."""
    model = SensorModel(SensorConfig(), ["target_tau_temperature"])
    fixed = model.unidentifiable(_campaign((22.0, 75.0), cooling_in_air=True))
    assert "tau_tempco2" in fixed and "tau_tempco" not in fixed
    assert "tau_tempco2" not in model.unidentifiable(_campaign((22.0, 50.0, 75.0), cooling_in_air=True))


def test_a_target_heated_only_while_the_coil_is_in_air_shows_no_tau_change():
    model = SensorModel(SensorConfig(), ["target_tau_temperature"])
    fixed = model.unidentifiable(_campaign((22.0,), cooling_in_air=True, hottest_c=75.0))
    assert "tau_tempco" in fixed and "tau_tempco2" in fixed
