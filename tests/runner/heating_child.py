"""A heating run in a child process that waits, heater on, to be killed by the test (see test_signals.py).

    python heating_child.py EXPERIMENT OUTPUT MARKER

When the simulated clock first passes MID_HEATING_S it writes MARKER (the heater is on then) and
sleeps in real time, so the parent's signal arrives while heating. At exit it prints the simulated
supply's output states as JSON on the last line of stdout.
"""

from __future__ import annotations

import atexit
import json
import sys
import time
from pathlib import Path

import ecds_lab.runner.session
from ecds_lab.cli import main
from ecds_lab.clock import SimulatedClock

MID_HEATING_S = 1800.0
experiment, output, marker = sys.argv[1:4]
stations = []
real_open = ecds_lab.runner.session.open_station
real_sleep = SimulatedClock.sleep


def keep(*args, **kwargs):
    station = real_open(*args, **kwargs)
    stations.append(station)
    return station


def sleep(self, seconds):
    real_sleep(self, seconds)
    if self.now() >= MID_HEATING_S and not Path(marker).exists():
        on = any(out.on for out in stations[0].lab.supply.values())
        Path(marker).write_text("heater on" if on else "heater off")
        for _ in range(600):
            time.sleep(0.1)


def report_supply():
    if stations:
        print(json.dumps({str(n): out.on for n, out in stations[0].lab.supply.items()}), flush=True)


ecds_lab.runner.session.open_station = keep
SimulatedClock.sleep = sleep
atexit.register(report_supply)
sys.exit(main(["run", experiment, "-o", output, "-q"]))
