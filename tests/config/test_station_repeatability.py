"""A station's ``slide.repeatability_um``: the slide's datasheet repeatability, accepted on the slide only,
never negative; the shipped simulated stations declare theirs, the real-station template does not."""

from __future__ import annotations

import math

import pytest

from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.station import StationConfig
from ecds_lab.errors import ConfigError


@pytest.mark.parametrize("name", ["simulated_lab", "simulated_lab_in_air", "simulated_lab_steel"])
def test_the_shipped_simulated_stations_declare_their_slides_datasheet_figure(experiments_dir, name):
    config = load_yaml_model(experiments_dir / "stations" / f"{name}.yaml", StationConfig)
    assert config.slide.repeatability_um == 5.0


def test_a_real_station_may_declare_it_and_without_it_declares_none(yaml_copy):
    assert load_yaml_model(yaml_copy("stations/real_lab_template.yaml"), StationConfig).slide.repeatability_um is None
    path = yaml_copy("stations/real_lab_template.yaml", lambda d: d["slide"].update(repeatability_um=12.5))
    assert load_yaml_model(path, StationConfig).slide.repeatability_um == 12.5


@pytest.mark.parametrize("value", [-1.0, math.nan])
def test_a_negative_or_unknown_repeatability_is_refused_naming_the_key(yaml_copy, value):
    path = yaml_copy("stations/simulated_lab.yaml", lambda d: d["slide"].update(repeatability_um=value))
    with pytest.raises(ConfigError) as raised:
        load_yaml_model(path, StationConfig)
    message = str(raised.value)
    assert str(path) in message and "slide.repeatability_um" in message
    assert ">= 0" in message or "finite number" in message


def test_repeatability_belongs_to_the_slide_only(yaml_copy):
    path = yaml_copy("stations/simulated_lab.yaml", lambda d: d["bridge"].update(repeatability_um=5.0))
    with pytest.raises(ConfigError, match=r"bridge: repeatability_um belongs to the slide"):
        load_yaml_model(path, StationConfig)
