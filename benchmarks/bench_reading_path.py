"""The instrument path of one reading, piece by piece (issue 17): what bench_throughput's points cost apart from
the run file.

Opens the default faithful station as bench_throughput does (pacing off, instant time) and times, in CPU time
(``time.process_time``, so a shared machine's other processes disturb the figures less), the best of a few
repetitions of: a bridge reading through driver, pyserial ``ecdssim://`` port and emulator (``HM8118.measure``,
frequency switched every ten readings as in the sweep), the lab's physics alone (``measured_impedance``), one
thermocouple scan through pyvisa-py (``DAQ970A.read_temperatures_c``; the runner scans about every fourth
reading) and a reply check (``XALL?`` reply format).
Usage: python benchmarks/bench_reading_path.py [--readings N] [--repeat N]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import yaml

from ecds_lab.config.station import StationConfig
from ecds_lab.drivers.hm8118 import XALL_REPLY
from ecds_lab.instruments import BridgeSettings
from ecds_lab.station import DEFAULT_STATION, Station, open_station


def bench_station() -> Station:
    """The default station as the throughput benchmark runs it, configured and at 40 mm."""
    data = yaml.safe_load(DEFAULT_STATION.read_text())
    data["simulated"]["pacing"] = False
    station = open_station(StationConfig.model_validate(data))
    station.bridge.configure(BridgeSettings(function="L-R", circuit="series", voltage_v=1.5, speed="slow"))
    station.scanner.configure()
    station.slide.home()
    station.slide.move_to(0.040)
    return station


def best_us(loop: Callable[[int], None], count: int, repeat: int) -> float:
    """CPU microseconds per call of the fastest of ``repeat`` loops of ``count`` calls."""
    best = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        loop(count)
        best = min(best, time.process_time() - start)
    return best / count * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--readings", type=int, default=5000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    station = bench_station()
    lab, bridge = station.lab, station.bridge

    def frequency(i: int) -> float:
        return 500.0 if (i // 10) % 2 else 15000.0

    def measure(n: int) -> None:
        for i in range(n):
            bridge.set_frequency(frequency(i))
            bridge.measure()
        for transport in station.transports.values():
            if transport.transcript is not None:
                transport.transcript.clear()

    def physics(n: int) -> None:
        for i in range(n):
            lab.clock.advance(0.6)
            lab.measured_impedance(frequency(i), "slow", 1.5, 1)

    def scan(n: int) -> None:
        for _ in range(n):
            lab.clock.advance(2.0)
            station.scanner.read_temperatures_c()

    def reply(n: int) -> None:
        for _ in range(n):
            XALL_REPLY.parse("4.72807E-02,5.13483E+01,0")

    figures = {
        "bridge reading (HM8118.measure, all layers)": best_us(measure, args.readings, args.repeat),
        "  of it: lab physics (measured_impedance)": best_us(physics, args.readings, args.repeat),
        "  of it: XALL? reply check": best_us(reply, args.readings, args.repeat),
        "thermocouple scan (DAQ970A.read_temperatures_c)": best_us(scan, max(1, args.readings // 5), args.repeat),
    }
    station.close()
    print(f"default faithful station, no pacing, CPU time, best of {args.repeat}:")
    for label, value in figures.items():
        print(f"  {label:50s} {value:7.2f} us")


if __name__ == "__main__":
    main()
