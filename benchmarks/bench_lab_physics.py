"""Cost of one bridge reading of the simulated lab, per physics and per what changed since the last one.

The lab is evaluated on every reading (``SimulatedLab.measured_impedance``), so its cost adds to every
point of a run. Prints microseconds per reading for the ECM physics and for the field physics
(Dodd & Deeds) when nothing changed (a steady sweep point), when the plate's temperature changed
(new reflection coefficient), when the distance changed (new lift-off factor) and when both did,
plus the one-off cost of tabulating the coil's kernel. Usage: python benchmarks/bench_lab_physics.py [--n N]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

from ecds_lab.simulators.campaign import move_to
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.simulators.physics.coil import CoilSettings
from ecds_lab.simulators.physics.field_solution import CoilKernel


def per_reading_us(lab: SimulatedLab, change: Callable[[SimulatedLab, int], None], n: int) -> float:
    best = float("inf")
    for _ in range(3):
        began = time.perf_counter()
        for i in range(n):
            change(lab, i)
            lab.measured_impedance(15000.0 if i % 2 else 500.0)
        best = min(best, (time.perf_counter() - began) / n * 1e6)
    return best


def nothing(lab: SimulatedLab, i: int) -> None:
    """A steady point: the same state, the two frequencies alternating."""


def plate_temperature(lab: SimulatedLab, i: int) -> None:
    lab.t_target_c = lab.t_plate_surface_c = 22.0 + 1e-3 * i


def distance(lab: SimulatedLab, i: int) -> None:
    lab.slide.motor_mm = lab.slide.move_to_mm = -140.0 + 1e-3 * i


def both(lab: SimulatedLab, i: int) -> None:
    plate_temperature(lab, i)
    distance(lab, i)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=5000, help="readings per case")
    n = parser.parse_args().n
    began = time.perf_counter()
    CoilKernel(CoilSettings().winding())
    print(f"coil kernel (once per geometry):            {(time.perf_counter() - began) * 1e3:8.1f} ms")
    for physics in ("ecm", "field"):
        lab = SimulatedLab(LabConfig(physics=physics, seed=0))
        move_to(lab, 20.0)
        cases = [("steady point", nothing)] if physics == "ecm" else [
            ("steady point", nothing), ("plate temperature changed", plate_temperature),
            ("distance changed", distance), ("temperature and distance changed", both)]
        for name, change in cases:
            print(f"{physics:5s} {name:36s} {per_reading_us(lab, change, n):8.1f} us/reading")


if __name__ == "__main__":
    main()
