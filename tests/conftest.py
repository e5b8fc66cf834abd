"""Fixtures shared by the whole suite: a fresh simulated lab per test and links into it."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from ecds_lab.clock import SimulatedClock
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.simulators.registry import emulator, register_lab
from ecds_lab.transports.serial_link import SerialTransport

_lab_numbers = itertools.count()


class LabHandle:
    """A registered simulated lab with helpers to open real transports into it."""

    def __init__(self, config: LabConfig) -> None:
        self.name = f"test{next(_lab_numbers)}"
        self.clock = SimulatedClock()
        self.lab = register_lab(self.name, SimulatedLab(config, self.clock))

    def url(self, instrument: str) -> str:
        return f"ecdssim://{self.name}/{instrument}"

    def serial(self, instrument: str, settings: dict[str, Any], **overrides: Any) -> SerialTransport:
        """A pyserial link to a simulated instrument, with the driver's link settings."""
        options = {**settings, **overrides}
        return SerialTransport(instrument, self.url(instrument), clock=self.clock, **options)

    def emulator(self, instrument: str):
        return emulator(self.name, instrument)

    def capture(self, instrument: str) -> bytearray:
        """Start capturing the exact bytes the host sends to an instrument."""
        emu = self.emulator(instrument)
        emu.wire = bytearray()
        return emu.wire


@pytest.fixture
def make_lab() -> Callable[..., LabHandle]:
    """Build a simulated lab from LabConfig keyword arguments."""
    return lambda **config: LabHandle(LabConfig(**config))


@pytest.fixture
def sim(make_lab: Callable[..., LabHandle]) -> LabHandle:
    """The default simulated lab: the paper's prototype coil facing a copper plate."""
    return make_lab()


@pytest.fixture
def open_sim_station():
    """Open stations on simulated labs (through the real drivers and transports); closed at teardown."""
    from ecds_lab.config.station import SimulationConfig, StationConfig
    from ecds_lab.instruments import BridgeSettings
    from ecds_lab.station import open_station

    opened = []

    def build(*, averages: int = 1, **lab: Any):
        config = StationConfig(simulated=SimulationConfig(lab=LabConfig(**lab), pacing=False))
        station = open_station(config)
        opened.append(station)
        station.bridge.configure(BridgeSettings(function="L-R", circuit="series", voltage_v=1.5, speed="slow",
                                                averages=averages))
        station.scanner.configure()
        station.slide.home()
        return station

    yield build
    for station in opened:
        station.close()


# -- experiments, run files and instrument guards (tests/config, tests/runner, tests/storage) ----------------

EXPERIMENTS = Path(__file__).resolve().parent.parent / "experiments"


@pytest.fixture
def experiments_dir() -> Path:
    """The shipped experiment and station YAML files."""
    return EXPERIMENTS


@pytest.fixture
def yaml_copy(tmp_path: Path) -> Callable[..., Path]:
    """Write a copy of a shipped YAML (path relative to experiments/) into tmp_path, edited by a callable.

    ``yaml_copy("displacement_sweep.yaml", lambda d: d["sweep"].update(repeats="twice"))``
    """
    import yaml

    def write(source: str, edit: Callable[[dict], Any] | None = None, *, name: str | None = None) -> Path:
        data = yaml.safe_load((EXPERIMENTS / source).read_text())
        if edit is not None:
            edit(data)
        path = tmp_path / (name or Path(source).name)
        path.write_text(yaml.safe_dump(data, sort_keys=False))
        return path

    return write


@dataclass
class InstrumentGuard:
    """What reached the instruments while the guard was on: opened stations, links and sent commands."""

    stations: list[str] = field(default_factory=list)
    links: list[str] = field(default_factory=list)
    sent: list[tuple[str, str]] = field(default_factory=list)

    @property
    def untouched(self) -> bool:
        return not (self.stations or self.links or self.sent)


@pytest.fixture
def instrument_guard(monkeypatch: pytest.MonkeyPatch) -> InstrumentGuard:
    """Record (and swallow) every station opened, link created and command sent; tests assert ``untouched``."""
    import ecds_lab.runner.session
    import ecds_lab.station
    from ecds_lab.errors import EcdsLabError
    from ecds_lab.transports.base import Transport

    guard = InstrumentGuard()
    real_init = Transport.__init__

    def refuse_station(*args: Any, **kwargs: Any) -> None:
        guard.stations.append("open_station")
        raise EcdsLabError("instrument_guard: a station was opened")

    def init(self: Transport, name: str, **kwargs: Any) -> None:
        guard.links.append(name)
        real_init(self, name, **kwargs)

    monkeypatch.setattr(ecds_lab.runner.session, "open_station", refuse_station)
    monkeypatch.setattr(ecds_lab.station, "open_station", refuse_station)
    monkeypatch.setattr(Transport, "__init__", init)
    # every command goes out through _send_logged (write, write_bytes and query alike)
    monkeypatch.setattr(Transport, "_send_logged", lambda self, text, data: guard.sent.append((self.name, text)))
    return guard


@pytest.fixture(scope="session")
def shipped_run(tmp_path_factory: pytest.TempPathFactory) -> Callable[..., Any]:
    """Run a shipped experiment once per session (default: the simulated lab); returns its RunResult.

    ``shipped_run("displacement_sweep.yaml")``, ``shipped_run("target_heating_steel.yaml",
    "stations/simulated_lab_steel.yaml")``. Call it only where nothing is monkeypatched.
    """
    from ecds_lab.runner.session import run_experiment

    results: dict[tuple[str, str | None], Any] = {}

    def run(experiment: str, station: str | None = None) -> Any:
        key = (experiment, station)
        if key not in results:
            output = tmp_path_factory.mktemp("shipped") / f"{Path(experiment).stem}.h5"
            results[key] = run_experiment(EXPERIMENTS / experiment, EXPERIMENTS / station if station else None,
                                          output, progress=False)
        return results[key]

    return run


# -- run files as earlier versions wrote them (tests/storage, tests/replay) ------------------------------------

def _to_per_role_transcripts(f: Any, transcripts: dict[str, list[Any]]) -> None:
    """Replace an open run file's transcript log with the layout written before decision 0006: one group per
    role, ``events`` (N x 4 float64: clock_s, wall_s, kind code, end offset into ``text``) and ``text`` (bytes)."""
    import numpy as np

    from ecds_lab.transports.transcript import KINDS

    group = f["entry/transcripts"]
    del group["log"]
    for role, events in transcripts.items():
        encoded = [e.text.encode("utf-8") for e in events]
        ends = np.cumsum([len(text) for text in encoded])
        table = [(e.clock_s, e.wall_s, float(KINDS.index(e.kind)), float(end))
                 for e, end in zip(events, ends, strict=True)]
        per_role = group.create_group(role)
        out = per_role.create_dataset("events", data=np.array(table, "<f8").reshape(-1, 4), maxshape=(None, 4),
                                      chunks=(64, 4))
        out.attrs["columns"] = ["clock_s", "wall_s", "kind", "text_end"]
        per_role.create_dataset("text", data=np.frombuffer(b"".join(encoded), "u1"), maxshape=(None,),
                                chunks=(2048,))


@pytest.fixture
def per_role_transcripts() -> Callable[[Path], Path]:
    """``per_role_transcripts(path)``: the closed run file at ``path`` rewritten in place with the transcript
    layout of files written before the transcript log (one ``events``/``text`` group per role)."""
    import h5py

    from ecds_lab.storage.reader import read_run

    def rewrite(path: Path) -> Path:
        transcripts = read_run(path).transcripts
        with h5py.File(path, "a") as f:
            _to_per_role_transcripts(f, transcripts)
        return path

    return rewrite
