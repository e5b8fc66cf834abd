"""The package's layers import only downward, so no import cycle can form between them.

errors, clock, shipped, forked < data < transports, instruments < drivers, simulators < config < station < runner,
storage < model < analysis < report, planning < the commands (cli, demo, replay, live, testing). Every import in
the source counts, including the ones inside functions.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: Folder in the checkout -> the import name it installs as.
SOURCES = {ROOT / "ecds_lab": "ecds_lab", ROOT / "drivers": "ecds_lab.drivers",
           ROOT / "simulators": "ecds_lab.simulators"}

#: Layer of each part of ecds_lab; a module may import its own part and parts of a lower layer.
LAYERS: dict[str, int] = {
    "errors": -1, "clock": -1, "shipped": -1, "forked": -1,
    "data": 0,
    "transports": 1, "instruments": 1,
    "drivers": 2, "simulators": 2,
    "config": 3,
    "station": 4,
    "runner": 5, "storage": 5,
    "model": 6,
    "analysis": 7,
    "report": 8,
    # designs, runs and re-diagnoses experiments (issue 26): above the analysis it scores with and the runner it
    # drives; beside the report, which reads its investigate.json without importing it
    "planning": 8,
}
#: Parts above everything: the command line and the tools built on all layers.
TOP = 9
#: Imports between two parts of the same layer that the design allows (the runner writes the run file).
SAME_LAYER_ALLOWED = {("runner", "storage")}


def part_of(module: str) -> str | None:
    """'ecds_lab.analysis.fitting' -> 'analysis'; None for modules outside ecds_lab."""
    names = module.split(".")
    if names[0] != "ecds_lab":
        return None
    if len(names) == 1 or names[1].startswith("__"):
        return "__init__"  # the package itself and its dunders (__version__)
    return names[1]


def layer(part: str) -> int:
    return LAYERS.get(part, TOP)


def modules() -> list[tuple[str, Path]]:
    found = []
    for folder, package in SOURCES.items():
        for path in sorted(folder.rglob("*.py")):
            relative = path.relative_to(folder).with_suffix("")
            names = [n for n in relative.parts if n != "__init__"]
            found.append((".".join([package, *names]), path))
    return found


def imports_of(module: str, path: Path) -> set[str]:
    """Every module name the file imports (relative imports resolved)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join([*base, node.module] if node.module else base)
            else:
                target = node.module or ""
            names.add(target)
            names.update(f"{target}.{alias.name}" for alias in node.names)
    return names


def violations() -> list[str]:
    found = []
    for module, path in modules():
        own = part_of(module)
        assert own is not None
        for imported in sorted(imports_of(module, path)):
            other = part_of(imported)
            if other is None or other in (own, "__init__"):
                continue
            if layer(other) < layer(own) or (own, other) in SAME_LAYER_ALLOWED:
                continue
            if layer(other) == TOP == layer(own):
                continue
            found.append(f"{path.relative_to(ROOT)}: {own} (layer {layer(own)}) imports {imported} "
                         f"({other}, layer {layer(other)})")
    return found


def test_every_import_points_down_the_layers() -> None:
    assert violations() == []


def test_the_walk_finds_the_modules_and_sees_upward_imports(tmp_path: Path) -> None:
    names = {m for m, _ in modules()}
    assert {"ecds_lab.data.measurements", "ecds_lab.drivers.grbl", "ecds_lab.simulators.lab",
            "ecds_lab.runner.runner", "ecds_lab.cli"} <= names
    upward = tmp_path / "bad.py"
    upward.write_text("def f():\n    from ecds_lab.analysis.fitting import fit\n    from ..model import ecm\n")
    seen = imports_of("ecds_lab.storage.bad", upward)
    assert "ecds_lab.analysis.fitting" in seen and "ecds_lab.model" in seen


@pytest.mark.parametrize(("importer", "imported"), [("storage", "analysis"), ("simulators", "drivers"),
                                                    ("drivers", "simulators"), ("data", "model"),
                                                    ("simulators", "config"), ("model", "analysis")])
def test_the_order_forbids_the_cycles_the_design_rules_out(importer: str, imported: str) -> None:
    assert not (layer(imported) < layer(importer) or (importer, imported) in SAME_LAYER_ALLOWED)
