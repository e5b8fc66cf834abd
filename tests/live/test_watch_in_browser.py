"""`ecds-lab run --watch` in headless Chromium: the page follows the run as it grows and ends on `completed`."""

from __future__ import annotations

import re
import subprocess
import sys
import time

PAGE = """({status: document.getElementById('status').textContent,
           points: Number(document.getElementById('points').textContent),
           rows: Number(document.getElementById('rows').textContent),
           images: [...document.images].map(i => i.complete && i.naturalWidth > 0)})"""


def test_the_live_page_follows_a_simulated_run_to_completed(chromium, tmp_path, experiments_dir, yaml_copy):
    slow = yaml_copy("stations/simulated_lab.yaml", lambda d: d["simulated"].update(real_time_factor=0.02))
    output = tmp_path / "run.h5"
    process = subprocess.Popen([sys.executable, "-m", "ecds_lab.cli", "run", str(experiments_dir /
                                "displacement_sweep.yaml"), "--station", str(slow), "-o", str(output), "-q",
                                "--watch"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = process.stdout.readline()
        url = re.search(r"http://127\.0\.0\.1:\d+/", line)
        assert url, line
        page = chromium.open(url.group(0))
        seen, deadline = [], time.monotonic() + 120
        while time.monotonic() < deadline:
            state = chromium.evaluate(PAGE)
            seen.append(state)
            if state["status"] not in ("running", "waiting for the run file", "…"):
                break
            time.sleep(0.5)
        assert seen[-1]["status"] == "completed", seen[-3:]
        counts = [s["points"] for s in seen if s["status"] == "running"]
        assert len(set(counts)) >= 3 and counts == sorted(counts), counts  # grows while the run writes
        assert seen[-1]["points"] == seen[-1]["rows"] == 248
        for _ in range(20):  # the plots of the final state are reloading
            images = chromium.evaluate(PAGE)["images"]
            if all(images):
                break
            time.sleep(0.5)
        assert all(images) and len(images) == 2
        assert page.errors() == []
        foreign = [u for u in page.requests if not u.startswith(url.group(0)) and not u.startswith("data:")]
        assert foreign == []
    finally:
        process.terminate()
        process.wait(timeout=10)
