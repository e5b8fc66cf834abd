"""The stations, sensors and experiments shipped with ecds-lab, wherever it is installed.

They live in the checkout's top-level ``experiments/`` and install as the package data of
``ecds_lab.experiments`` (setup.py), so they are found through ``importlib.resources`` both in a
wheel install and in an editable one, never by walking up from ``__file__``.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def experiments_folder() -> Path:
    """The folder holding the shipped experiment YAMLs (with ``stations/`` and ``sensors/`` in it)."""
    root = resources.files("ecds_lab.experiments")
    if not isinstance(root, Path):
        raise RuntimeError(f"ecds-lab's shipped experiments must be installed as plain files, found {root!r}")
    return root


def experiment(name: str) -> Path:
    """A shipped experiment YAML by file name, e.g. ``displacement_sweep.yaml``."""
    return _existing(experiments_folder() / name)


def station(name: str = "simulated_lab.yaml") -> Path:
    """A shipped station YAML by file name; the default is the simulated lab."""
    return _existing(stations_folder() / name)


def stations_folder() -> Path:
    """The folder holding the shipped station YAMLs (the simulated labs, the real lab's template)."""
    return experiments_folder() / "stations"


def sensors_folder() -> Path:
    """The folder holding the shipped sensor YAMLs (the paper's prototype, the steel target)."""
    return experiments_folder() / "sensors"


def experiments() -> list[Path]:
    """Every shipped experiment YAML, sorted by name."""
    return sorted(experiments_folder().glob("*.yaml"))


def _existing(path: Path) -> Path:
    if not path.is_file():
        known = ", ".join(p.name for p in sorted(path.parent.glob("*.yaml")))
        raise FileNotFoundError(f"no shipped file {path.name!r} in {path.parent}; shipped: {known}")
    return path
