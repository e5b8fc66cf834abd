"""The paper's equivalent circuit model as the simulated lab's physics (``physics: ecm``).

Gruber et al. 2024, Eq. (1)-(4): L_coil = L0 (1 + alpha dT + beta dT^2), R_coil with the wire's
tempco, the target as a secondary with a single time constant tau_T coupled by k(x)^2:

    L = L_coil (1 - k^2 f_T),  R = R_coil + k^2 w^2 tau_T L_coil / (1 + (w tau_T)^2),
    f_T = (w tau_T)^2 / (1 + (w tau_T)^2),

then the former's parallel C and loss. k(x)^2 = M_image(x) / L_self from Maxwell's filament
formula (image method, ``filaments``) or a table of k(x). This is the model the analysis fits, so
on this physics the analysis is exact; the faithful lab is ``physics: field``.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from ecds_lab.simulators.physics.field_solution import Winding
from ecds_lab.simulators.physics.filaments import image_mutual, self_inductance
from ecds_lab.simulators.physics.plate import MATERIALS, material_key


def eddy_factor(omega: float, tau_s: float) -> float:
    """f_T = (w tau)^2 / (1 + (w tau)^2), Eq. (2)."""
    wt2 = (omega * tau_s) ** 2
    return wt2 / (1.0 + wt2)


def series_branch(l_coil_h: float, r_coil_ohm: float, k2: float, omega: float, tau_s: float) -> complex:
    """R + jwL of coil and target, Eq. (2) and (3)."""
    inductance = l_coil_h * (1.0 - k2 * eddy_factor(omega, tau_s))
    resistance = r_coil_ohm + k2 * omega**2 * tau_s * l_coil_h / (1.0 + (omega * tau_s) ** 2)
    return complex(resistance, omega * inductance)


def with_parallel(z_series: complex, omega: float, capacitance_f: float, conductance_s: float) -> complex:
    """The series branch in parallel with the former's capacitance and loss conductance."""
    return 1.0 / (1.0 / z_series + complex(conductance_s, omega * capacitance_f))


class ImageCoupling:
    """k(x)^2 of the winding to a perfectly conducting plane (image method), remembered per distance."""

    def __init__(self, coil: Winding, radial: int, axial: int) -> None:
        self.coil, self.radial, self.axial = coil, radial, axial
        self.self_h = self_inductance(coil, radial, axial)
        self._last: tuple[float, float] = (math.nan, 0.0)

    def k2(self, x_m: float) -> float:
        if x_m != self._last[0]:
            self._last = (x_m, image_mutual(self.coil, x_m, self.radial, self.axial) / self.self_h)
        return self._last[1]


class TableCoupling:
    """k(x)^2 from a CSV of ``x_mm,k`` (linear interpolation in x, k clamped at the table's ends)."""

    def __init__(self, path: Path) -> None:
        try:
            with open(path, newline="") as handle:
                rows = [(float(r["x_mm"]) * 1e-3, float(r["k"])) for r in csv.DictReader(handle)]
        except (OSError, KeyError, ValueError) as exc:
            raise ValueError(f"coupling table {path}: needs columns x_mm,k with numbers ({exc})") from exc
        if len(rows) < 2:
            raise ValueError(f"coupling table {path}: needs at least two rows")
        rows.sort()
        self.x, self.k = np.array([r[0] for r in rows]), np.array([r[1] for r in rows])

    def k2(self, x_m: float) -> float:
        return float(np.interp(x_m, self.x, self.k)) ** 2


#: ECM effect ``target_tau_temperature``: relative change of tau_T per kelvin by target material. tau_T = L_T/R_T
#: grows with the plate's conductivity, so a non-magnetic plate's tau_T falls by its resistivity tempco
#: (``plate.MATERIALS``, handbook: copper 0.39 %/K, aluminium 0.43 %/K, brass 0.15 %/K); steel's, whose mu_r
#: rises too, taken as 0.30 %/K.
TAU_TEMPCO_PER_K = {"steel": -0.0030, **{name: -material.resistivity_tempco_per_k
                                          for name, material in MATERIALS.items() if material.mu_r_20c == 1.0}}


def tau_tempco_per_k(material: str) -> float:
    """The default relative change of tau_T per kelvin of a ``material`` plate; an unknown one is a ValueError."""
    return TAU_TEMPCO_PER_K[material_key(material)]
