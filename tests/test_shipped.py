"""The shipped stations, sensors and experiments are found through the package, not the checkout's layout."""

from __future__ import annotations

import pytest

from ecds_lab import shipped
from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.station import StationConfig
from ecds_lab.data.sensor import load_sensor
from ecds_lab.demo import CAMPAIGN


def test_every_campaign_file_of_the_demo_is_shipped():
    for experiment, station in CAMPAIGN:
        assert shipped.experiment(experiment).is_file()
        assert shipped.station(station).is_file()


def test_the_shipped_stations_and_sensors_validate():
    stations = sorted((shipped.experiments_folder() / "stations").glob("*.yaml"))
    assert {p.name for p in stations} >= {"simulated_lab.yaml", "real_lab_template.yaml"}
    for path in stations:
        load_yaml_model(path, StationConfig)
    sensors = sorted(shipped.sensors_folder().glob("*.yaml"))
    assert {load_sensor(p).target for p in sensors} == {"copper", "steel"}


def test_shipped_experiments_are_listed_by_name():
    names = [p.name for p in shipped.experiments()]
    assert "displacement_sweep.yaml" in names
    assert names == sorted(names)


def test_an_unknown_shipped_file_names_what_is_shipped():
    with pytest.raises(FileNotFoundError, match=r"simulated_lab\.yaml"):
        shipped.station("no_such_station.yaml")
