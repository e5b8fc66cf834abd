"""What an experiment or station argument names: a file, or else a file shipped with ecds-lab.

``ecds-lab run displacement_sweep --station simulated_lab`` works from any folder after a plain
``pip install .``: an existing file wins (so a user's own ``displacement_sweep.yaml`` in the current
folder is the one run), otherwise a bare name (``displacement_sweep`` or ``displacement_sweep.yaml``,
no folder) is looked up among the shipped files (``ecds_lab/shipped.py``). Anything else is one
ConfigError naming what was given and every shipped name.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

from ecds_lab import shipped
from ecds_lab.errors import ConfigError

SUFFIXES = (".yaml", ".yml")

#: The station used when none is given, by its shipped name.
DEFAULT_STATION_NAME = "simulated_lab"


def shipped_experiment_names() -> list[str]:
    """Names of the shipped experiments (``displacement_sweep``, ...), sorted."""
    return [path.stem for path in shipped.experiments()]


def shipped_station_names() -> list[str]:
    """Names of the shipped stations (``simulated_lab``, ``real_lab_template``, ...), sorted."""
    return sorted(path.stem for path in shipped.stations_folder().glob("*.yaml"))


def experiment_path(reference: str | Path) -> Path:
    """The experiment YAML an argument names: an existing file, else a shipped experiment's name."""
    return _resolve(reference, "experiment", shipped.experiments_folder(), shipped_experiment_names())


def station_path(reference: str | Path | None) -> Path:
    """The station YAML an argument names (None: the shipped simulated lab): a file, else a shipped name."""
    if reference is None:
        reference = DEFAULT_STATION_NAME
    return _resolve(reference, "station", shipped.stations_folder(), shipped_station_names())


def _bare_name(text: str) -> str | None:
    """The name a reference gives when it has no folder part (``x`` or ``x.yaml``), else None."""
    if "/" in text or "\\" in text or not text or text.startswith("."):
        return None
    for suffix in SUFFIXES:
        if text.endswith(suffix):
            return text[: -len(suffix)]
    return text


def _resolve(reference: str | Path, what: str, folder: Path, names: list[str]) -> Path:
    text = str(reference)
    given = Path(text)
    if given.exists():
        return given  # a file, or a folder that read_text refuses naming it
    name = _bare_name(text)
    if name in names:
        return folder / f"{name}.yaml"
    shipped_names = f"shipped {what}s: {', '.join(names)} (see `ecds-lab list`)"
    if name is None:
        raise ConfigError(f"{text}: cannot read: {os.strerror(errno.ENOENT)} (a shipped {what} is named without "
                          f"a folder; {shipped_names})")
    raise ConfigError(f"{text}: no such file, and no shipped {what} of that name; {shipped_names}")
