"""The effect library: one small module per physical effect the baseline ECM leaves out.

Each module defines one ``Effect`` subclass (see ``ecds_lab.model.effects`` for the stage hooks)
and ``@register``s it. Importing this package imports every module in it, so the registry
(``ecds_lab.model.effects.library()``) is what counts: adding an effect is adding a module.
"""

from __future__ import annotations

import importlib
import pkgutil

for _module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    importlib.import_module(f"{__name__}.{_module.name}")
