"""parasitic_capacitance's swelling: the moist former strains the winding, s = 1 + e (m - 1), so drying shrinks the
coil: its inductance by s, and the coupling is the cold coil's at the distance (x - p1) / s. The strain is a share of
the capacitance the same water adds, e = k dC / C_ref."""

from __future__ import annotations

import numpy as np
import pytest

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.model.parameters import values_of
from ecds_lab.model.sensor_model import SensorModel

#: A former that dries within minutes of reaching 40 C (a threshold at 35 C), adding 15 pF when moist (the paper's
#: Table 2; C_ref 50 pF for its coil), and no loss.
DRYING = {"moist_dC": 15e-12, "moist_dG": 0.0, "drying_rate": 1e-2, "drying_onset": 35.0, "drying_width": 1.0,
          "drying_order": 1.0, "bound_share": 0.0}
#: The swelling that strains the winding by 150 ppm with those 15 pF: k = 150e-6 / (15 / 50).
SWELLING = 150e-6 / (15.0 / 50.0)


def _heated(x_mm: float, freqs_hz: tuple[float, ...] = (500.0,)) -> Measurements:
    """Readings a minute apart at one position (inf: in air), the coil held at 22 C for an hour, then at 80 C."""
    t_coil = np.repeat([22.0, 80.0], 60)
    n = len(t_coil)
    freq = np.resize(np.asarray(freqs_hz, float), n)
    return Measurements(time_s=np.arange(n) * 60.0, x_m=np.full(n, x_mm * 1e-3), freq_hz=freq, t_coil_c=t_coil,
                        t_target_c=np.full(n, 22.0), ls_h=np.full(n, 0.05), rs_ohm=np.full(n, 20.0))


@pytest.fixture
def model() -> SensorModel:
    return SensorModel(SensorConfig(), ["parasitic_capacitance"])


def _values(model: SensorModel, **changes: float) -> dict[str, float]:
    return values_of(model.parameters()) | DRYING | changes


def test_the_strain_is_the_swellings_share_of_the_capacitance(model):
    effect = model.effect("parasitic_capacitance")
    assert effect.strain(_values(model, moist_swelling=SWELLING)) == pytest.approx(150e-6)
    assert effect.strain(_values(model, moist_swelling=SWELLING, moist_dC=0.0)) == 0.0  # no water, no swelling


def test_drying_shrinks_the_coil_in_air_by_the_strain(model):
    data = _heated(np.inf)
    ratio = model.predict(data, _values(model, moist_swelling=SWELLING)) / model.predict(data, _values(model))
    assert ratio[:60] == pytest.approx(1.0, abs=1e-7)  # moist, as at the start
    assert ratio[-1] == pytest.approx(1.0 - 150e-6, abs=2e-7)  # dry: the winding 150 ppm smaller


def test_the_dry_coil_couples_as_the_moist_one_would_further_away(model):
    """Near the plate a smaller coil couples less: L rises beyond the shrink of L itself, as at a larger distance.
    (The parallel capacitance and the loss are not scaled: they differ by a part in 10^7 here.)"""
    near = _heated(20.0)
    values = _values(model, moist_swelling=SWELLING)
    shrunk = model.predict(near, values)[-1]
    unstrained = model.predict(near, values | {"moist_swelling": 0.0})[-1]
    scale = 1.0 - 150e-6
    farther = model.predict(near, values | {"moist_swelling": 0.0},
                            x_m=values["p1"] + (near.x_m - values["p1"]) / scale)[-1]
    assert shrunk == pytest.approx(farther * scale, rel=1e-7)  # the parallel C and the loss: not scaled
    assert shrunk / unstrained > scale  # the coupling's share goes the other way


def test_one_frequency_holds_the_swelling_two_free_it(model):
    assert "moist_swelling" in model.unidentifiable(_heated(20.0))
    assert "moist_swelling" not in model.unidentifiable(_heated(20.0, (500.0, 15000.0)))
