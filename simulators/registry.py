"""Named simulated labs and the emulators attached to them.

``ecdssim://LAB/INSTRUMENT`` resolves here: LAB names a registered ``SimulatedLab``
and INSTRUMENT an emulator kind. Each lab keeps one emulator per instrument, so a
re-opened port finds the instrument in the state it was left in, as hardware would.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from ecds_lab.instruments.kinds import KINDS
from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.simulators.urlhandler import register_scheme

_LABS: dict[str, SimulatedLab] = {}
_EMULATORS: dict[tuple[str, str], LineEmulator] = {}
_LOCK = threading.Lock()


def _emulator_class(instrument: str) -> Callable[[SimulatedLab], LineEmulator]:
    """The emulator class the instrument table names for ``instrument`` (imported on first use)."""
    if instrument not in KINDS:
        raise KeyError(f"no simulated instrument {instrument!r}; choose one of {sorted(KINDS)}")
    emulator_class: Callable[[SimulatedLab], LineEmulator] = KINDS[instrument].emulator_class()
    return emulator_class


def register_lab(name: str, lab: SimulatedLab) -> SimulatedLab:
    """Make ``lab`` reachable as ``ecdssim://name/...``; replaces a lab of the same name."""
    register_scheme()
    with _LOCK:
        _LABS[name] = lab
        for key in [k for k in _EMULATORS if k[0] == name]:
            del _EMULATORS[key]
    return lab


def get_lab(name: str) -> SimulatedLab:
    with _LOCK:
        if name not in _LABS:
            raise KeyError(f"no simulated lab named {name!r} (registered: {sorted(_LABS) or 'none'})")
        return _LABS[name]


def emulator(lab_name: str, instrument: str) -> LineEmulator:
    """The emulator of ``instrument`` in lab ``lab_name``, created on first use."""
    factory = _emulator_class(instrument)
    lab = get_lab(lab_name)
    with _LOCK:
        key = (lab_name, instrument)
        if key not in _EMULATORS:
            _EMULATORS[key] = factory(lab)
        return _EMULATORS[key]
