"""A metal object beside the slide: near one position it couples to the coil and lowers L a little."""

from typing import ClassVar

import numpy as np

from ecds_lab.model.effects import Effect
from ecds_lab.model.parameters import Parameter


class MetalObject(Effect):
    name = "metal_object"
    explains = "a metal object beside the slide lowers L near one position"
    plausible: ClassVar[dict[str, tuple[float, float]]] = {"object_ppm": (-5000.0, 5000.0)}
    key_parameters = ("object_ppm",)

    def parameters(self):
        return [Parameter("object_ppm", 0.0, -1e4, 1e4, "ppm", "change of L at the object", 50.0),
                Parameter("object_x", 0.045, 0.02, 0.10, "m", "slide position of the object", 2e-3),
                Parameter("object_width", 0.005, 0.001, 0.03, "m", "width of its influence", 1e-3)]

    def series_inductance(self, l_h, inputs, data, p):
        x = np.where(np.isfinite(data.x_m), data.x_m, np.inf)
        bump = np.exp(-0.5 * ((x - p["object_x"]) / p["object_width"]) ** 2)
        return l_h * (1 + 1e-6 * p["object_ppm"] * bump)
