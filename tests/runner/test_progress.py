"""The progress bar: rows against the rows the run will write, an ETA from the plan's time estimate."""

from __future__ import annotations

import fcntl
import os
import pty
import re
import struct
import subprocess
import sys
import termios
import time

from ecds_lab.runner.plan import build_plan
from ecds_lab.runner.progress import PlanEstimate
from ecds_lab.runner.session import load_experiment
from ecds_lab.runner.steps import WaitSteady

#: tqdm's line: "... 123/330 rows [00:12, ETA 00:17, ...]"
BAR = re.compile(r"(\d+)/(\d+) rows \[(\d+):(\d+), ETA (\d+):(\d+)")


def test_a_finished_heating_wait_calibrates_the_later_ones(experiments_dir):
    plan = build_plan(load_experiment(experiments_dir / "coil_heating.yaml"))
    estimate = PlanEstimate(plan)
    waits = [i for i, s in enumerate(plan.steps) if isinstance(s, WaitSteady)]
    before = estimate.seconds(waits[1])
    estimate.observe(waits[0], 3 * estimate.seconds(waits[0]))
    assert estimate.seconds(waits[1]) == 3 * before
    assert estimate.remaining_s(waits[1], 0.0) > estimate.remaining_s(waits[1] + 1, 0.0)


def test_the_eta_on_the_coil_heating_run_is_within_30_percent_from_a_quarter_on(tmp_path, experiments_dir,
                                                                                 yaml_copy):
    # the simulated lab slowed so the 2.4 h (simulated) run takes about 30 s; the bar drawn on a terminal
    station = yaml_copy("stations/simulated_lab.yaml",
                        lambda d: d["simulated"].update(real_time_factor=30.0 / 8700.0))
    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 160, 0, 0))  # a 160-column terminal
    started = time.monotonic()
    process = subprocess.Popen([sys.executable, "-m", "ecds_lab.cli", "run", str(experiments_dir / "coil_heating.yaml"),
                                "--station", str(station), "-o", str(tmp_path / "run.h5")],
                               stdout=follower, stderr=follower, stdin=subprocess.DEVNULL)
    os.close(follower)
    samples, text = [], b""
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:
            break
        if not chunk:
            break
        text += chunk
        for match in BAR.finditer(chunk.decode(errors="replace")):
            samples.append((time.monotonic() - started, *map(int, match.groups())))
    process.wait(timeout=120)
    actual = time.monotonic() - started
    assert process.returncode == 0, text.decode(errors="replace")[-2000:]
    assert b"completed" in text
    later = [(t, done, total, eta_m * 60 + eta_s) for t, done, total, _, _, eta_m, eta_s in samples
             if t >= 0.25 * actual]
    assert len(later) >= 10, text.decode(errors="replace")[-1500:]
    errors = [abs(t + eta - actual) / actual for t, _, _, eta in later]
    median = sorted(errors)[len(errors) // 2]
    print(f"\nrun {actual:.1f} s; ETA error from 25 % on: max {max(errors):.0%}, median {median:.0%}")
    for (t, _, _, eta), error in zip(later, errors, strict=True):
        assert error <= 0.3, (t, eta, actual)
    # the bar ends on the rows the run wrote, its total being those rows
    done, total = later[-1][1:3]
    assert done == total > 300


def test_the_dry_run_summary_counts_steps_readings_duration_temperatures_and_travel(experiments_dir):
    sweep = build_plan(load_experiment(experiments_dir / "displacement_sweep.yaml"))
    text = sweep.summary()
    assert "248 MeasurePoint" in text and "1 Home" in text
    assert "readings: 248 planned, about 0 logged" in text and "temperatures: no heating" in text
    assert "slide travel: 160.0 mm" in text  # 20 -> 100 mm and back
    heating = build_plan(load_experiment(experiments_dir / "coil_heating.yaml"))
    text = heating.summary()
    assert "5 WaitSteady" in text and "1 CoolDown" in text and "temperatures: 40 C to 130 C" in text
    minutes = float(re.search(r"estimated duration: ([\d.]+) min", text).group(1))
    assert abs(minutes * 60 - PlanEstimate(heating).total_s()) < 6
    assert heating.describe().endswith(text)
