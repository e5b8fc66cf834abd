"""A killed run's transcript covers every kept reading, so its replay reproduces the part that was measured."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from ecds_lab.replay import format_replay, replay_run
from ecds_lab.storage.reader import read_run


def test_replay_of_a_killed_run_reproduces_the_measured_part(tmp_path, experiments_dir):
    path = tmp_path / "killed.h5"
    code = textwrap.dedent(f"""
        import os
        from ecds_lab.cli import main
        from ecds_lab.storage.run_file import RunWriter
        real = RunWriter.append_row
        def append_row(self, row):
            real(self, row)
            if self.rows == 57:
                os._exit(9)
        RunWriter.append_row = append_row
        main(["run", {str(experiments_dir / "displacement_sweep.yaml")!r}, "-o", {str(path)!r}, "-q"])
    """)
    assert subprocess.run([sys.executable, "-c", code], timeout=120, check=False).returncode == 9
    assert read_run(path).status == "interrupted"
    result = replay_run(path)
    assert result.partial and result.reproduced, result.differences
    assert result.original_points == result.replayed_points == 57
    text = format_replay(result)
    assert "replayed the part it measured" in text and "reproduced: every row equal" in text
    assert "NOT reproduced" not in text
    # the replay's links ran out, not a heater: no call to switch one off by hand, no error, a truthful ending
    assert "BY HAND" not in text.upper() and "switch off" not in text.lower().replace("nothing to switch off", "")
    assert result.error == "" and result.replay_status == "stopped where the recording ends"
    assert "the replay drives no instrument" in text
