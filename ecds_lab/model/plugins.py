"""The user's own effects, without editing ecds-lab: a Python file or an installed package.

A file (``--effects-from my_effects.py``) is imported as a module; every ``Effect`` subclass it
defines with a ``name`` joins the registry it is loaded into (``with_effects_files``: a new
registry, the library's unchanged). An installed package declares entry points in the group
``ecds_lab.effects`` (``[project.entry-points."ecds_lab.effects"] my_effect = "my_pkg.effects:MyEffect"``),
each naming an ``Effect`` subclass or a module of them; ``library()`` includes them. The command line
hands the registry to ``fit --effects``, ``diagnose`` and ``report``, which use them like the library's own.
"""

from __future__ import annotations

import importlib.util
import inspect
import logging
import sys
from collections.abc import Iterable
from functools import cache
from importlib.metadata import entry_points
from pathlib import Path
from types import ModuleType

from ecds_lab.errors import EcdsLabError
from ecds_lab.model.effects import Effect, EffectRegistry, library

log = logging.getLogger("ecds_lab.model")

ENTRY_POINT_GROUP = "ecds_lab.effects"


class EffectPluginError(EcdsLabError, ValueError):
    """A user's effect file or entry point cannot be used; the message names it and why."""


def effects_in(module: ModuleType) -> list[type[Effect]]:
    """The named ``Effect`` subclasses a module defines itself (not those it imports)."""
    return [obj for _, obj in inspect.getmembers(module, inspect.isclass)
            if issubclass(obj, Effect) and obj is not Effect and obj.name and obj.__module__ == module.__name__]


def _enter(registry: EffectRegistry, cls: type[Effect], origin: str) -> None:
    try:
        registry.add(cls, origin)
    except ValueError as exc:
        raise EffectPluginError(str(exc)) from exc


def load_effects_file(path: str | Path, registry: EffectRegistry) -> list[str]:
    """Import a Python file of effects and add them to ``registry``; returns their names."""
    path = Path(path)
    if not path.is_file():
        raise EffectPluginError(f"--effects-from {path}: no such file")
    name = f"ecds_lab_user_effects_{abs(hash(str(path.resolve())))}"
    if name in sys.modules:
        module = sys.modules[name]
    else:
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise EffectPluginError(f"--effects-from {path}: not a Python file")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except Exception as exc:
            del sys.modules[name]
            raise EffectPluginError(f"--effects-from {path}: importing it failed: {type(exc).__name__}: {exc}") from exc
    found = effects_in(module)
    if not found:
        raise EffectPluginError(f"--effects-from {path}: defines no Effect subclass with a name "
                                "(class MyEffect(Effect): name = 'my_effect' ...)")
    for cls in found:
        _enter(registry, cls, f"--effects-from {path}")
    return [cls.name for cls in found]


def with_effects_files(paths: Iterable[str | Path], registry: EffectRegistry | None = None) -> EffectRegistry:
    """A new registry: ``registry`` (default: the library and installed packages') plus every file's effects."""
    out = (registry if registry is not None else library()).with_effects()
    for path in paths:
        load_effects_file(path, out)
    return out


@cache
def entry_point_effects() -> tuple[tuple[type[Effect], str], ...]:
    """The effects installed packages declare (group ``ecds_lab.effects``) with their origin, loaded once
    per process (installed packages do not change while it runs).

    An entry point that fails to load is logged and skipped: one broken package must not stop the
    analysis of data that do not need it."""
    found: list[tuple[type[Effect], str]] = []
    for point in entry_points(group=ENTRY_POINT_GROUP):
        origin = f"entry point {point.name} = {point.value}"
        try:
            target = point.load()
            classes = effects_in(target) if isinstance(target, ModuleType) else [target]
            for cls in classes:
                if not (inspect.isclass(cls) and issubclass(cls, Effect) and cls.name):
                    raise EffectPluginError(f"{cls!r} is not an Effect subclass with a name")
                found.append((cls, origin))
        except Exception as exc:
            log.warning("effect entry point %s = %s not loaded: %s", point.name, point.value, exc)
    return tuple(found)


def load_entry_points() -> list[str]:
    """The names of the effects installed packages declare (``entry_point_effects``)."""
    return [cls.name for cls, _ in entry_point_effects()]
