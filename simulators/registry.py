"""Named simulated labs and the emulators attached to them.

``ecdssim://LAB/INSTRUMENT`` resolves here: LAB names a registered ``SimulatedLab``
and INSTRUMENT an emulator kind. Each lab keeps one emulator per instrument, so a
re-opened port finds the instrument in the state it was left in, as hardware would.
"""

from __future__ import annotations

import importlib
import threading
from typing import Callable

from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.lab import SimulatedLab

_LABS: dict[str, SimulatedLab] = {}
_EMULATORS: dict[tuple[str, str], LineEmulator] = {}
_LOCK = threading.Lock()


#: Instrument name in ``ecdssim://`` URLs -> "module:class" of its emulator (imported on first use).
EMULATOR_KINDS = {
    "hm8118": "ecds_lab.simulators.hm8118:HM8118Emulator",
    "grbl": "ecds_lab.simulators.grbl:GrblEmulator",
    "daq970a": "ecds_lab.simulators.daq970a:DAQ970AEmulator",
    "34970a": "ecds_lab.simulators.daq970a:Keysight34970AEmulator",
    "hmp4040": "ecds_lab.simulators.hmp:HMPEmulator",
}


def _emulator_class(instrument: str) -> Callable[[SimulatedLab], LineEmulator]:
    if instrument not in EMULATOR_KINDS:
        raise KeyError(f"no simulated instrument {instrument!r}; choose one of {sorted(EMULATOR_KINDS)}")
    module, _, cls = EMULATOR_KINDS[instrument].partition(":")
    return getattr(importlib.import_module(module), cls)


def register_lab(name: str, lab: SimulatedLab) -> SimulatedLab:
    """Make ``lab`` reachable as ``ecdssim://name/...``; replaces a lab of the same name."""
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
