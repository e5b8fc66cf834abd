"""benchmarks/diagnosis_guard.py tells a changed conclusion from the same one."""

from __future__ import annotations

import copy
import importlib.util
import json
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "diagnosis_guard.py"
_SPEC = importlib.util.spec_from_file_location("diagnosis_guard", _PATH)
assert _SPEC is not None and _SPEC.loader is not None
guard = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(guard)


def _diagnosis() -> dict:
    return {"verdict": "missing_effect", "claimed": ["slide_backlash"], "alternatives": [["b", "a"]], "partial": [],
            "undetermined": [], "untestable": {"tau_displacement": "one frequency"}, "outliers": [{"row": 7}],
            "noise_ppm": 23.1, "baseline": {"rmse_ppm": 1670.0},
            "steps": [{"effects": [], "rmse_ppm": 1670.0}, {"effects": ["slide_backlash"], "rmse_ppm": 92.4}]}


def test_the_same_diagnosis_and_rounding_noise_conclude_the_same():
    before = guard.conclusion(_diagnosis())
    nudged = _diagnosis()
    nudged["steps"][-1]["rmse_ppm"] = 92.4 * (1 + 1e-5)
    nudged["alternatives"] = [["a", "b"]]  # the order within a group is not a conclusion
    assert guard.differences(before, guard.conclusion(nudged), 1e-3) == []


@pytest.mark.parametrize("change", ["claim", "rmse", "glitch"])
def test_a_changed_claim_rmse_or_glitch_is_a_changed_conclusion(change: str):
    before = guard.conclusion(_diagnosis())
    after = copy.deepcopy(_diagnosis())
    if change == "claim":
        after["claimed"] = []
    elif change == "rmse":
        after["steps"][-1]["rmse_ppm"] = 95.0
    else:
        after["outliers"].append({"row": 9})
    found = guard.differences(before, guard.conclusion(after), 1e-3)
    assert len(found) == 1 and found[0].startswith({"claim": "claimed", "rmse": "final_rmse_ppm",
                                                    "glitch": "outliers"}[change])


def test_compare_exits_1_on_a_changed_conclusion(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    reference, same, changed = tmp_path / "ref" / "c.json", tmp_path / "same" / "c.json", tmp_path / "new" / "c.json"
    unclaimed = {**_diagnosis(), "claimed": []}
    for path, diagnosis in ((reference, _diagnosis()), (same, _diagnosis()), (changed, unclaimed)):
        path.parent.mkdir()
        path.write_text(json.dumps(diagnosis))
    baseline = tmp_path / "baseline.json"
    assert guard.main(["record", str(reference), "-o", str(baseline)]) == 0
    assert guard.main(["compare", str(baseline), str(same)]) == 0
    assert guard.main(["compare", str(baseline), str(changed)]) == 1
    assert "CHANGED" in capsys.readouterr().out
