"""The paper comparison finds its runs by what they hold, not by their names (issue 24, point 5)."""

from __future__ import annotations

import shutil
from pathlib import Path
from types import SimpleNamespace

from ecds_lab.analysis.paper_comparison import paper_comparison, runs_by_role
from ecds_lab.report.inputs import load_inputs
from ecds_lab.report.paper_section import paper_comparison_section
from ecds_lab.storage.data_file import open_data


def test_renamed_run_files_keep_the_paper_section(campaign_files: list[Path], tmp_path: Path):
    renamed = []
    for i, path in enumerate(reversed(campaign_files)):
        target = tmp_path / f"measurement {i:02d}.h5"
        shutil.copyfile(path, target)
        renamed.append(target)
    roles = runs_by_role([open_data(p) for p in renamed])
    assert set(roles) == {"displacement_sweep", "coil_heating", "spectroscopy", "target_heating_copper",
                          "target_heating_steel"}
    original, moved = paper_comparison(campaign_files), paper_comparison(renamed)
    assert len(moved) >= 15 and moved == original
    section = "".join(paper_comparison_section(SimpleNamespace(inputs=load_inputs(renamed))))  # type: ignore[arg-type]
    assert "Omitted" not in section and section.count("<tr>") == len(original) + 1


def test_the_comparison_says_what_the_data_show_not_how_a_simulator_works(campaign_files: list[Path]):
    text = " ".join(f"{r['quantity']} {r['how']}" for r in paper_comparison(campaign_files)).lower()
    for internal in ("simulat", "the lab's", "dodd", "deeds", "geometric l", "follows the paper's sec. 3.1 law"):
        assert internal not in text
