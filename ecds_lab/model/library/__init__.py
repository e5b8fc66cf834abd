"""The effect library: one small module per physical effect the baseline ECM leaves out.

Each module defines one ``Effect`` subclass (see ``ecds_lab.model.effects`` for the
stage hooks). To add an effect: write a module like these, with its parameters
(unit, bounds, a prior scale) and the hook it changes, and list its class in ``LIBRARY``.
"""

from __future__ import annotations

from ecds_lab.model.library.former_expansion import FormerExpansion
from ecds_lab.model.library.magnetic_depth import MagneticDepth
from ecds_lab.model.library.parasitic_capacitance import ParasiticCapacitance
from ecds_lab.model.library.plate_recession import PlateRecession
from ecds_lab.model.library.slide_backlash import SlideBacklash
from ecds_lab.model.library.slide_lead_screw import SlideLeadScrew
from ecds_lab.model.library.target_bending import TargetBending
from ecds_lab.model.library.target_tau_temperature import TargetTauTemperature
from ecds_lab.model.library.tau_displacement import TauDisplacement
from ecds_lab.model.library.thermal_lag import ThermalLag

LIBRARY = (TargetTauTemperature, TauDisplacement, TargetBending, ParasiticCapacitance, ThermalLag, SlideBacklash,
           FormerExpansion, SlideLeadScrew, PlateRecession, MagneticDepth)
