"""The bottom layers stay generic: transports and the instrument table import no driver, simulator or config."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "ecds_lab"
#: What ecds_lab/transports and ecds_lab/instruments may import from the project.
ALLOWED = ("ecds_lab.clock", "ecds_lab.errors", "ecds_lab.transports", "ecds_lab.instruments")


def project_imports(path: Path) -> list[str]:
    modules: list[str] = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            modules += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            modules.append(node.module)
        elif isinstance(node, ast.ImportFrom):
            raise AssertionError(f"{path.name}: relative import {node.module!r}")
    return [m for m in modules if m.split(".")[0] == "ecds_lab"]


BOTTOM = sorted([*(PACKAGE / "transports").glob("*.py"), *(PACKAGE / "instruments").glob("*.py")])


@pytest.mark.parametrize("path", BOTTOM, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_bottom_layers_import_nothing_above_them(path):
    above = [m for m in project_imports(path) if not m.startswith(ALLOWED)]
    assert above == [], f"{path.parent.name}/{path.name} imports {above}"


def test_transports_do_not_mention_the_simulator_package():
    for path in (PACKAGE / "transports").glob("*.py"):
        assert "ecds_lab.simulators" not in path.read_text(), path.name
