"""The target materials a sensor YAML may name: each has a tau_T start, the non-magnetic ones a resistivity, and
the effects that depend on the material follow it."""

from __future__ import annotations

from typing import get_args

import pytest
from pydantic import ValidationError

from ecds_lab.data.sensor import NON_MAGNETIC_RESISTIVITY_OHM_M, TARGET_TAU_S, SensorConfig, TargetMaterial
from ecds_lab.model.library.magnetic_depth import MagneticDepth
from ecds_lab.model.library.plate_recession import PlateRecession

MATERIALS = get_args(TargetMaterial)


def test_every_material_has_a_tau_start_and_every_one_but_steel_a_resistivity():
    assert set(TARGET_TAU_S) == set(MATERIALS)
    assert set(NON_MAGNETIC_RESISTIVITY_OHM_M) == set(MATERIALS) - {"steel"}


@pytest.mark.parametrize("material", ["aluminium", "brass"])
def test_a_non_magnetic_plate_starts_at_coppers_tau_scaled_by_its_conductivity(material):
    ratio = NON_MAGNETIC_RESISTIVITY_OHM_M["copper"] / NON_MAGNETIC_RESISTIVITY_OHM_M[material]
    assert SensorConfig(target=material).target_tau_s == pytest.approx(TARGET_TAU_S["copper"] * ratio)
    assert SensorConfig(target=material).target_tau_s < SensorConfig(target="copper").target_tau_s


def test_the_us_spelling_names_aluminium():
    assert SensorConfig(target="aluminum").target == "aluminium"
    assert SensorConfig(target=" Aluminum ").target == "aluminium"


def test_an_unknown_target_names_every_one_it_could_be():
    with pytest.raises(ValidationError, match="'copper', 'aluminium', 'brass' or 'steel'"):
        SensorConfig(target="gold")


@pytest.mark.parametrize("material", MATERIALS)
def test_only_steel_screens_from_a_magnetic_depth_and_every_other_plate_recedes_by_its_skin_depth(material):
    sensor = SensorConfig(target=material)
    assert MagneticDepth.applies_to(sensor) == (material == "steel")
    resistivity = PlateRecession(sensor).resistivity_ohm_m
    assert resistivity == NON_MAGNETIC_RESISTIVITY_OHM_M.get(material)
