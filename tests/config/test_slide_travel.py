"""Config checks read the slide's travel from what its driver declares, never by building or inspecting one."""

from __future__ import annotations

from ecds_lab.config.checks import slide_travel_mm
from ecds_lab.config.station import StationConfig
from ecds_lab.drivers.grbl import Grbl


def _refuse(*args: object, **kwargs: object) -> None:
    raise AssertionError("a config check built a driver")


def test_declared_travel_is_read_without_building_the_driver(monkeypatch):
    monkeypatch.setattr(Grbl, "__init__", _refuse)
    assert slide_travel_mm(StationConfig(simulated={})) == Grbl.default_travel_mm == (15.0, 160.0)


def test_station_options_override_the_declared_travel():
    station = StationConfig(simulated={}, slide={"driver": "grbl", "options": {"max_mm": 120}})
    assert slide_travel_mm(station) == (15.0, 120.0)


def test_a_changed_declaration_is_what_the_check_uses(monkeypatch):
    monkeypatch.setattr(Grbl, "default_travel_mm", (5.0, 50.0))
    assert slide_travel_mm(StationConfig(simulated={})) == (5.0, 50.0)
