"""Simulators stand on their own: the emulators are written from the manuals (no driver imports) and the
simulated lab's physics is its own (no imports of the analysis or its model)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SIMULATORS = Path(__file__).resolve().parents[2] / "simulators"


def imported_modules(path: Path) -> list[str]:
    """Every module a source file imports, absolute names as written (``from x import y`` gives x and x.y)."""
    names: list[str] = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = "." * node.level + (node.module or "")
            names += [base, *(f"{base}.{alias.name}" for alias in node.names)]
    return names


def _is_driver(module: str) -> bool:
    parts = module.lstrip(".").split(".")
    return parts[:2] == ["ecds_lab", "drivers"] or parts[0] == "drivers"


@pytest.mark.parametrize("path", sorted(SIMULATORS.rglob("*.py")), ids=lambda p: str(p.relative_to(SIMULATORS)))
def test_no_simulator_imports_a_driver(path):
    offending = [module for module in imported_modules(path) if _is_driver(module)]
    assert offending == [], f"{path.name} imports {offending}"


def test_the_check_sees_a_driver_import(tmp_path):
    source = tmp_path / "copied.py"
    source.write_text("from ecds_lab.drivers.hm8118 import FREQUENCIES_HZ\nfrom ecds_lab import drivers\n")
    assert [m for m in imported_modules(source) if _is_driver(m)] == [
        "ecds_lab.drivers.hm8118", "ecds_lab.drivers.hm8118.FREQUENCIES_HZ", "ecds_lab.drivers"]


def test_every_simulator_module_was_checked():
    assert {"hm8118.py", "daq970a.py", "hmp.py", "grbl.py", "registry.py"} <= {p.name for p in SIMULATORS.rglob("*.py")}


def test_no_simulator_module_imports_the_model_or_the_analysis():
    files = sorted(SIMULATORS.rglob("*.py"))
    assert any(p.parent.name == "physics" for p in files)  # the walk sees the physics package
    offenders = [f"{p.relative_to(SIMULATORS)}: {name}" for p in files for name in imported_modules(p)
                 if name.lstrip(".").startswith(("ecds_lab.model", "ecds_lab.analysis"))]
    assert offenders == []
