"""plate_recession: a plate thick against the skin depth screens from behind its face, deeper at low frequency.

The paper's ECM holds one tau_T and one calibration for every frequency. A non-magnetic plate of thickness d
reflects the coil's field, to first order in (field's spatial frequency) x (skin depth), like a perfect
conductor at the complex depth c = coth(gamma d)/gamma behind its face, gamma = (1 + j)/delta, delta =
sqrt(2 rho/(omega mu_0)) (Dodd & Deeds' reflection coefficient expanded, docs/physics.md "Two frequencies on a
thick plate"). Its real part, the recession, is delta/2 when d >> delta and d/3, alike at every frequency, for
a sheet thin against delta. The coil therefore senses the distance x + Re{c(f)}: for the 5 mm copper plate
about 1.4 mm at 500 Hz and 0.27 mm at 15 kHz. The calibration's offset p1 takes any shift common to all
frequencies; what is left is the difference between frequencies, which one offset cannot follow.

The skin depth comes from the sensor's target material (copper's textbook resistivity, as for
``target_tau_temperature``); the one unknown is the plate's thickness, ``plate_thickness``: two frequencies
tell it through how much deeper the lower one senses (from d/3 for a sheet to delta/2 once d exceeds about
2 delta). A plate thicker than about three skin depths at the lowest frequency recedes by delta/2 whatever its
thickness, so the thickness is a nuisance parameter and the key one is ``recession_scale``, the set-back over
the textbook material's (1: the material as declared; for a thick plate sqrt(rho/rho_textbook)): two
frequencies determine it through the difference of set-back between them, whatever the thickness. At one
frequency the recession is one shift of the distance, taken by p1: untestable there.

Not in the baseline: the first-order recession misdescribes plates comparable to the skin depth (there tau_T(x)
is the better description, ``tau_displacement``), and it leaves the next term, -(Im c)^2/2 d^2k^2/dx^2 on k^2,
as structure; the diagnosis adds it when two frequencies ask for it. With it the ECM's screening factor is
free to go to 1 (tau_T at its upper bound): the recession then carries the screening of a thick plate.
A magnetic target (steel) has a skin depth far below a millimetre at both frequencies and its own
permeability's action: the effect does nothing there and is untestable.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import NON_MAGNETIC_RESISTIVITY_OHM_M
from ecds_lab.model.effects import GIVEN_BY_SENSOR, Effect, register
from ecds_lab.model.library.target_tau_temperature import (
    per_frequency,
    recession_and_derivatives_m,
    skin_depth_m,
)
from ecds_lab.model.parameters import Parameter
from ecds_lab.model.tangents import Tangent, plus


@register
class PlateRecession(Effect):
    name = "plate_recession"
    explains = ("a plate thick against the skin depth screens like a perfect conductor set back behind its face, "
                "deeper at lower frequency (delta/2 ~ f^-1/2): the sensed distance differs between frequencies")
    #: recession_scale s multiplies the material's recession; for a thick plate (Re c = delta/2) it is
    #: sqrt(rho/rho_textbook): silver 0.97 is the best conductor there is, annealed to hard-drawn copper
    #: grades 1.00-1.03, copper alloys sold as copper plate (CuCrZr, CuNi) up to ~1.5, and the plate's
    #: temperature over 0-100 C adds +-15 %. A quarter beyond either end for the first-order recession's own
    #: error (its next term, -(Im c)^2/2 d2k^2/dx^2, is not modelled): 0.75-1.9.
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"recession_scale": (0.75, 1.9)}
    key_parameters = ("recession_scale",)
    #: Two frequencies tell one difference of set-back; a plate thicker than ~3 skin depths at the lowest
    #: frequency recedes by delta/2 whatever its thickness: then the thickness is not determined.
    nuisance_parameters = ("plate_thickness",)
    #: One plate: its conductivity change (``target_tau_temperature``) recedes through the same thickness.
    shared_parameters = ("plate_thickness",)
    #: A plate comparable to delta(500 Hz) of copper (2.9 mm) and a thin one: the recession's difference
    #: between frequencies rises to a flat maximum in d, so more than one start.
    alternative_starts: ClassVar[tuple[dict[str, float], ...]] = ({"plate_thickness": 3e-3},
                                                                  {"plate_thickness": 1e-3})
    #: Tried by the diagnosis only when named (``run_diagnosis(..., candidates=...)``): at two frequencies a free
    #: tau_T(x) (``tau_displacement``) follows the same 500 Hz change in x and the two tie on a thick plate, where
    #: tau_displacement alone was claimed before (the faithful lab's paper campaign: 4079 against 4041 noise
    #: variances gained).
    tried_by_default = False
    #: No set-back at all: the ECM's screening alone.
    absent_form: ClassVar[dict[str, float]] = {"recession_scale": 0.0}
    reveal = ("measure the same positions at 500 Hz and at 15 kHz: a thick plate's screening depth, the skin "
              "depth's half, differs between them by about a millimetre for copper")
    reveal_needs: ClassVar[dict[str, float]] = {"frequencies": 2}

    @property
    def resistivity_ohm_m(self) -> float | None:
        """The target's resistivity at 20 C if it is non-magnetic (its recession is modelled), else None."""
        return NON_MAGNETIC_RESISTIVITY_OHM_M.get(self.sensor.target)

    def parameters(self) -> list[Parameter]:
        known = self.sensor.target_thickness_m
        return [Parameter("recession_scale", 1.0, 0.0, 5.0, "1",
                          "set-back of the plate's screening over the textbook material's Re{coth(gamma d)/gamma}",
                          0.1),
                Parameter("plate_thickness", known if known is not None else 10e-3, 1e-6, 50e-3, "m",
                          "thickness of the target plate that sets its skin recession at each frequency", 1e-3)]

    def unidentifiable(self, data: Measurements) -> dict[str, str]:
        both = ("recession_scale", "plate_thickness")
        if self.resistivity_ohm_m is None:
            return dict.fromkeys(both, f"a magnetic target ({self.sensor.target}): no skin recession modelled")
        finite = np.isfinite(data.x_m)
        if len(np.unique(data.freq_hz[finite])) < 2:
            return dict.fromkeys(both, "fewer than two frequencies with the target present: the recession is one "
                                       "shift of the distance, taken by p1")
        if self.sensor.target_thickness_m is not None:
            return {"plate_thickness": GIVEN_BY_SENSOR}
        return {}

    def effective_distance(self, x_m: np.ndarray, data: Measurements, p: Mapping[str, float]) -> np.ndarray:
        return self.d_effective_distance(x_m, {}, data, p)[0]

    def d_effective_distance(self, x_m: np.ndarray, dx: Tangent, data: Measurements,
                             p: Mapping[str, float]) -> tuple[np.ndarray, Tangent]:
        rho = self.resistivity_ohm_m
        if rho is None:
            return x_m, dx
        thickness, scale = p["plate_thickness"], p["recession_scale"]
        recession, _, by_thickness = per_frequency(lambda d: recession_and_derivatives_m(d, thickness),
                                                   skin_depth_m(rho, data.freq_hz))
        return x_m + scale * recession, plus(dx, {"recession_scale": recession,
                                                  "plate_thickness": scale * by_thickness})
