"""`ecds-lab watch RUN.h5` in its own process: follows another process's run, and outlives a killed run."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import urllib.request


def get(url: str) -> bytes:
    with urllib.request.urlopen(url, timeout=10) as response:
        return response.read()


def test_watch_follows_a_run_in_another_process_and_keeps_serving_after_it_is_killed(tmp_path, experiments_dir,
                                                                                       yaml_copy):
    slow = yaml_copy("stations/simulated_lab.yaml", lambda d: d["simulated"].update(real_time_factor=0.02))
    path = tmp_path / "run.h5"
    watch = subprocess.Popen([sys.executable, "-m", "ecds_lab.cli", "watch", str(path)], stdout=subprocess.PIPE,
                             text=True)
    sweep = experiments_dir / "displacement_sweep.yaml"
    run = subprocess.Popen([sys.executable, "-m", "ecds_lab.cli", "run", str(sweep), "--station", str(slow),
                            "-o", str(path), "-q"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        url = re.search(r"http://127\.0\.0\.1:\d+/", watch.stdout.readline()).group(0)
        assert b"<progress" in get(url)
        rows, deadline = [], time.monotonic() + 60
        while (not rows or rows[-1] < 30 or len(set(rows)) < 3) and time.monotonic() < deadline:
            status = json.loads(get(url + "status.json"))
            rows.append(status["rows"])
            time.sleep(0.3)
        assert rows[-1] >= 30 and len(set(rows)) >= 3, rows
        assert status["status"] == "running" and 0 < status["fraction"] < 1 and status["remaining_s"] > 0
        os.kill(run.pid, signal.SIGKILL)
        run.wait(timeout=10)
        time.sleep(1.5)  # past the snapshot's cache
        after = json.loads(get(url + "status.json"))
        assert after["rows"] >= rows[-1] and after["plotted_points"] == after["rows"]
        assert after["status"] == "running"  # what the killed file says; 'stalled' after 5 min unchanged
        assert get(url + "ls.png")[:8] == b"\x89PNG\r\n\x1a\n"
    finally:
        for process in (run, watch):
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()
    assert watch.returncode == 0
