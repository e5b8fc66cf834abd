"""The simulated lab's plate materials beyond the paper's copper and steel: aluminium and brass (handbook physics,
docs/simulated_lab.md "Plate"), in both physics modes."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from pydantic import ValidationError

from ecds_lab.simulators.campaign import move_to
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab
from ecds_lab.simulators.physics import ecm
from ecds_lab.simulators.physics.coil import CoilSettings
from ecds_lab.simulators.physics.field_sensor import FieldSensor
from ecds_lab.simulators.physics.plate import Plate, PlateSettings

QUIET = {"noise": {"enabled": False}, "accuracy": {"enabled": False}, "glitches": {"enabled": False}}
MU0 = 4e-7 * math.pi
#: Handbook figures the lab's materials must carry: sigma at 20 C (S/m), resistivity tempco (1/K), expansion (1/K).
HANDBOOK = {"copper": (58e6, 0.0039, 16.5e-6), "aluminium": (37.7e6, 0.0043, 23.1e-6), "brass": (15.5e6, 0.0015, 20e-6)}
NEW = ("aluminium", "brass")
#: Every target material, in the order of falling thermal conductivity (400, 237, 120, 45 W/mK).
BY_THERMAL_CONDUCTIVITY = ("copper", "aluminium", "brass", "steel")


@pytest.fixture
def plate_lab() -> Callable[..., SimulatedLab]:
    """A quiet faithful lab facing a plate of ``material`` (``plate`` settings as keywords)."""
    return lambda material, **plate: SimulatedLab(LabConfig(physics="field", bridge=QUIET,
                                                            sensor={"target": material}, plate=plate))


@pytest.fixture
def ecm_lab() -> Callable[..., SimulatedLab]:
    """A lab on the paper's equivalent circuit facing a ``material`` target, tau_T following its temperature."""
    return lambda material, tempco=None: SimulatedLab(LabConfig(
        sensor={"target": material},
        effects={"target_tau_temperature": {"enabled": True, "tempco_per_k": tempco}}))


def inductance(lab: SimulatedLab, frequency_hz: float) -> float:
    return lab.coil_impedance(frequency_hz).imag / (2 * math.pi * frequency_hz)


def change_20_to_100_mm(lab: SimulatedLab, frequency_hz: float) -> float:
    """How much L rises from 20 to 100 mm (H)."""
    move_to(lab, 20.0)
    near = inductance(lab, frequency_hz)
    move_to(lab, 100.0)
    return inductance(lab, frequency_hz) - near


def test_aluminium_lies_between_copper_and_a_poor_conductor_at_500_hz(plate_lab):
    """Skin depth at 500 Hz: copper 2.9 mm, aluminium 3.7 mm, brass 5.7 mm, a 1 MS/m plate 22 mm: the deeper the
    field reaches into the 5 mm plate, the less it screens, so the change in L falls with the conductivity."""
    change = {material: change_20_to_100_mm(plate_lab(material), 500.0) for material in ("copper", *NEW)}
    poor = change_20_to_100_mm(plate_lab("copper", conductivity={"sigma_20c_s_per_m": 1e6}), 500.0)
    assert change["copper"] > change["aluminium"] > change["brass"] > poor > 0
    assert change["copper"] - change["aluminium"] < change["aluminium"] - poor  # aluminium is nearly copper


@pytest.mark.parametrize("material", NEW)
def test_a_thick_plate_recedes_by_half_its_skin_depth(material):
    """At 15 kHz every non-magnetic plate here is thick (delta <= 1.04 mm against 5 mm): its eddy currents flow
    delta/2 below the surface, so it screens like copper placed (delta - delta_Cu)/2 further away."""
    omega = 2 * math.pi * 15e3

    def reflected_l(name: str, x_m: float) -> float:
        return FieldSensor(CoilSettings(), Plate(PlateSettings(), name)).plate_inductance(omega, x_m, 20, 20, 1).real

    def skin_depth(name: str) -> float:
        return math.sqrt(2 / (omega * MU0 * HANDBOOK[name][0]))

    for x in (0.02, 0.05):
        slope = (reflected_l("copper", x + 1e-6) - reflected_l("copper", x)) / 1e-6
        seen_further = (reflected_l(material, x) - reflected_l("copper", x)) / slope
        assert seen_further == pytest.approx((skin_depth(material) - skin_depth("copper")) / 2, rel=0.05)


@pytest.mark.parametrize("material", NEW)
def test_a_heated_plate_conducts_by_its_handbook_tempco(plate_lab, material):
    """sigma(T) = sigma20 / (1 + a (T - 20 C)): the hot plate reads as a cold one of that conductivity."""
    sigma20, tempco, _ = HANDBOOK[material]
    fixed = {"gradient": {"enabled": False}, "bending": {"enabled": False}}
    hot = plate_lab(material, **fixed)
    assert hot.plate.conductivity(20.0) == pytest.approx(sigma20, rel=1e-12)
    assert hot.plate.permeability(120.0) == 1.0
    twin = plate_lab(material, conductivity={"enabled": False, "sigma_20c_s_per_m": sigma20 / (1 + tempco * 100.0)},
                     **fixed)
    for lab in (hot, twin):
        move_to(lab, 20.0)
    cold = inductance(hot, 500.0)
    hot.t_target_c = hot.t_plate_surface_c = 120.0
    assert inductance(hot, 500.0) > cold  # a hotter plate conducts less: it screens less, L rises
    for frequency in (500.0, 15000.0):
        assert hot.coil_impedance(frequency) == pytest.approx(twin.coil_impedance(frequency), rel=1e-9)


def test_thermal_figures_follow_the_thermal_conductivity(plate_lab):
    """The better the plate conducts heat, the less its part under the winding runs ahead of the thermocouple and
    the sooner the thermocouple's surface follows the heated bulk."""
    gradient, surface = [], []
    for material in BY_THERMAL_CONDUCTIVITY:
        lab = plate_lab(material)
        gradient.append((lab.plate.field_temperature_c(55.0, 22.0) - 55.0) / (55.0 - 22.0))
        lab.t_target_c = 100.0
        lab.clock.advance(10.0)
        surface.append(lab.temperature_c("target"))
    assert gradient == sorted(gradient) and 0.01 <= gradient[1] < gradient[2] <= 0.06
    assert surface == sorted(surface, reverse=True) and surface[-1] > 22.0


@pytest.mark.parametrize("material", NEW)
def test_the_dome_grows_with_thermal_expansion(plate_lab, material):
    """Same plate, heaters and mount as copper's: the centre rise scales with the thermal strain."""
    args = (0.03, 120.0, 22.0, 0.065)
    ratio = plate_lab(material).plate.bending_shift_m(*args) / plate_lab("copper").plate.bending_shift_m(*args)
    assert ratio == pytest.approx(HANDBOOK[material][2] / HANDBOOK["copper"][2], rel=0.02)


@pytest.mark.parametrize("material, tempco", [("copper", -0.0039), ("aluminium", -0.0043), ("brass", -0.0015),
                                              ("steel", -0.0030)])
def test_ecm_tau_tempco_defaults_to_the_material(ecm_lab, material, tempco):
    """physics: ecm, target_tau_temperature: tau_T follows the plate's conductivity (steel's taken as -0.30 %/K)."""
    default, explicit = ecm_lab(material), ecm_lab(material, tempco)
    for lab in (default, explicit):
        move_to(lab, 30.0)
        lab.t_target_c = 120.0
    assert default.coil_impedance(500.0) == explicit.coil_impedance(500.0)
    assert ecm.tau_tempco_per_k(material) == tempco


def test_an_unknown_material_is_named():
    with pytest.raises(ValueError, match=r"plate material 'tin' is unknown.*copper, aluminium, brass, steel"):
        Plate(PlateSettings(), "tin")
    with pytest.raises(ValueError, match="'tin'"):
        ecm.tau_tempco_per_k("tin")
    with pytest.raises(ValidationError, match="tin"):
        LabConfig(physics="field", sensor={"target": "tin"})


def test_aluminum_is_aluminium():
    lab = SimulatedLab(LabConfig(physics="field", sensor={"target": "aluminum"}, plate={"material": "aluminum"}))
    assert lab.plate.material == "aluminium"
    assert lab.plate.sigma20 == HANDBOOK["aluminium"][0]
