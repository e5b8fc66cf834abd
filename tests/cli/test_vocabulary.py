"""One vocabulary for readings, rows and planned readings (docs/data-contract.md, "Words"), used by the dry run,
the end of a run, the export and the replay; the counts they give agree with the file (issue 24, point 7)."""

from __future__ import annotations

import re
from pathlib import Path

from ecds_lab.cli import main
from ecds_lab.storage.reader import read_run

CONTRACT = Path(__file__).resolve().parents[2] / "docs" / "data-contract.md"
#: "point" as a count of data: the word the messages used for rows, for planned readings and for positions
POINTS = re.compile(r"\bpoints?\b")


def test_the_contract_defines_each_word():
    text = CONTRACT.read_text(encoding="utf-8")
    words = text.split("## Words", 1)[1].split("\n## ", 1)[0]
    for word in ("**reading**", "**row**", "**planned reading**", "**logged reading**", "**position**"):
        assert word in words, word


def test_dry_run_run_export_and_replay_count_in_the_same_words(tmp_path, capsys):
    assert main(["run", "coil_heating", "--dry-run"]) == 0
    dry = capsys.readouterr().out
    assert not POINTS.search(dry), POINTS.search(dry)
    header = dry.splitlines()[0]
    planned = int(re.search(r"(\d+) planned readings$", header).group(1))
    assert f"readings: {planned} planned, about " in dry
    about_rows = int(re.search(r"about (\d+) rows in the run file, one per reading", dry).group(1))

    run = tmp_path / "heating.h5"
    assert main(["run", "coil_heating", "-o", str(run), "-q"]) == 0
    ended = capsys.readouterr().out
    rows = len(read_run(run, transcripts=False).points)
    assert ended.startswith(f"completed: {rows} rows in {run}") and not POINTS.search(ended)
    assert f"(the plan has {planned} planned readings; readings logged while waiting on heaters come on top)" \
        in ended
    assert abs(about_rows - rows) <= 0.3 * rows  # the dry run's row count is an estimate of the same thing

    assert main(["export", str(run), "-o", str(tmp_path / "heating.csv")]) == 0
    exported = capsys.readouterr().out
    assert exported.startswith(f"{rows} rows (one per reading) -> ") and not POINTS.search(exported)

    assert main(["replay", str(run)]) == 0
    replayed = capsys.readouterr().out
    assert f"recorded {rows} rows (completed), replayed {rows} (completed)" in replayed
    assert "every row equal" in replayed and not POINTS.search(replayed)


def test_a_run_without_logging_does_not_claim_logged_readings(tmp_path, capsys):
    assert main(["run", "spectroscopy", "--station", "simulated_lab_in_air", "-o", str(tmp_path / "s.h5"),
                 "-q"]) == 0
    ended = capsys.readouterr().out
    rows = len(read_run(tmp_path / "s.h5", transcripts=False).points)
    assert ended.startswith(f"completed: {rows} rows in ") and "logged" not in ended
    assert f"(the plan has {rows} planned readings)" in ended
