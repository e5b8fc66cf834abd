"""The simulated lab's physics is its own: nothing under simulators/ imports the analysis or its model."""

from __future__ import annotations

import ast
from pathlib import Path

import ecds_lab.simulators

FORBIDDEN = ("ecds_lab.model", "ecds_lab.analysis")
#: Data descriptions, not physics, that still live in those packages until they move to ecds_lab.data
#: (issue 12; ecds_lab.data is allowed): module -> the one simulator file that may import it.
DATA_DESCRIPTIONS = {"ecds_lab.model.sensor": "config.py", "ecds_lab.analysis.dataset": "campaign.py"}


def _imports(path: Path) -> list[str]:
    names = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.append(node.module)
    return names


def test_no_simulator_module_imports_the_model_or_the_analysis():
    root = Path(ecds_lab.simulators.__file__).parent
    files = sorted(root.rglob("*.py"))
    assert any(p.parent.name == "physics" for p in files)  # the walk sees the physics package
    offenders = [f"{p.relative_to(root)}: {name}" for p in files for name in _imports(p)
                 if name.startswith(FORBIDDEN) and DATA_DESCRIPTIONS.get(name) != str(p.relative_to(root))]
    assert offenders == []
