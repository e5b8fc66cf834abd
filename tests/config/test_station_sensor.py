"""A station's ``sensor``: a shipped name, a path or inline; errors name the file and field;
a simulated station simulates the sensor it names."""

from __future__ import annotations

import pytest

from ecds_lab.config.loading import load_yaml_model
from ecds_lab.config.station import StationConfig
from ecds_lab.data.sensor import SensorConfig, load_sensor
from ecds_lab.errors import ConfigError


def station(yaml_copy, source: str, **top) -> StationConfig:
    path = yaml_copy(source, lambda d: d.update(top))
    return load_yaml_model(path, StationConfig)


def test_a_shipped_name_a_path_and_an_inline_sensor_give_the_same_description(yaml_copy, experiments_dir):
    steel = load_sensor("steel_target")
    assert station(yaml_copy, "stations/real_lab_template.yaml", sensor="steel_target").sensor == steel
    path = str(experiments_dir / "sensors" / "steel_target.yaml")
    assert station(yaml_copy, "stations/real_lab_template.yaml", sensor=path).sensor == steel
    inline = steel.model_dump(mode="json")
    assert station(yaml_copy, "stations/real_lab_template.yaml", sensor=inline).sensor == steel


def test_a_real_station_without_a_sensor_names_none(yaml_copy):
    path = yaml_copy("stations/real_lab_template.yaml", lambda d: d.pop("sensor"))
    assert load_yaml_model(path, StationConfig).sensor is None


def test_a_simulated_station_simulates_the_sensor_it_names(yaml_copy):
    config = station(yaml_copy, "stations/simulated_lab.yaml", sensor="steel_target")
    assert config.sensor == load_sensor("steel_target")
    assert config.simulated is not None and config.simulated.lab.sensor == config.sensor


def test_a_simulated_station_naming_none_records_its_labs_sensor(yaml_copy):
    def lab_sensor_only(d: dict) -> None:
        d.pop("sensor")
        d["simulated"]["lab"]["sensor"] = {"target": "steel"}

    config = load_yaml_model(yaml_copy("stations/simulated_lab.yaml", lab_sensor_only), StationConfig)
    assert config.sensor == SensorConfig(target="steel")


def test_two_different_sensors_for_one_simulated_station_are_refused(yaml_copy):
    path = yaml_copy("stations/simulated_lab_steel.yaml",
                     lambda d: d["simulated"]["lab"].update(sensor={"target": "copper"}))
    with pytest.raises(ConfigError, match=r"simulated\.lab\.sensor differs from the station's sensor"):
        load_yaml_model(path, StationConfig)


@pytest.mark.parametrize(("sensor", "message"), [
    ("brass_target", "sensor 'brass_target': no shipped sensor of that name; shipped: paper_prototype, steel_target"),
    ("missing/sensor.yaml", "missing/sensor.yaml: cannot read the sensor file"),
    ({"target": "gold"}, "field 'sensor.target': Input should be 'copper', 'aluminium', 'brass' or 'steel'"),
])
def test_a_bad_sensor_is_named_with_the_station_file(yaml_copy, sensor, message):
    path = yaml_copy("stations/real_lab_template.yaml", lambda d: d.update(sensor=sensor))
    with pytest.raises(ConfigError) as raised:
        load_yaml_model(path, StationConfig)
    assert str(raised.value).startswith(f"{path}: field 'sensor")
    assert message in str(raised.value)
