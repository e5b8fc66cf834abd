"""Pinned readings: speed work on the simulators and the instrument path must not change a single number.

The values below were computed with the code of main at 699995a (before issue 17's per-point speed work)
by running ``lab_scenario`` and a short sweep through the default station (``sweep_experiment``);
they are stored, not recomputed, so any change to the physics, the noise stream or the protocol traffic fails here.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
import yaml

from ecds_lab.runner.session import run_experiment
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import BOX_HEATER_OUTPUT, TARGET_HEATER_OUTPUT, SimulatedLab
from ecds_lab.station import load_station_config
from ecds_lab.storage.reader import read_run

STATIONS = Path(__file__).resolve().parents[2] / "experiments" / "stations"
#: Readings of the long series whose values are pinned (the noise stream runs through all of them).
PINNED_INDICES = (0, 1, 2, 357, 1000, 1999)


def _lab(station: str) -> SimulatedLab:
    """The lab of a shipped station YAML, or the paper's equivalent circuit lab for ``ecm``."""
    if station == "ecm":
        return SimulatedLab(LabConfig(physics="ecm"))
    config = load_station_config(STATIONS / station)[0]
    assert config.simulated is not None
    return SimulatedLab(config.simulated.lab)


def lab_scenario(station: str) -> list[float]:
    """Moves both ways, both heaters, three speeds and levels, then 2,000 readings over a slow sweep."""
    lab = _lab(station)
    out: list[float] = []

    def move(x_mm: float) -> None:
        lab.clock.advance(lab.start_move(x_mm, 600.0) + 2.0)

    def read(frequencies: tuple[float, ...], speed: str = "slow", volts: float = 1.5, averages: int = 1) -> None:
        for frequency in frequencies:
            lab.clock.advance(0.6)
            z = lab.measured_impedance(frequency, speed, volts, averages)
            out.extend((z.real, z.imag))
        true = lab.coil_impedance(15000.0)
        out.extend((true.real, true.imag, lab.temperature_c("coil"), lab.temperature_c("target")))

    move(40.0)
    read((500.0, 15000.0, 100000.0))
    lab.set_supply(TARGET_HEATER_OUTPUT, voltage_v=12.0, current_limit_a=2.0, on=True)
    lab.set_supply(BOX_HEATER_OUTPUT, voltage_v=8.0, current_limit_a=2.0, on=True)
    lab.clock.advance(600.0)
    read((500.0, 15000.0, 100000.0), "medium", 1.0)
    move(25.0)
    read((500.0, 15000.0, 200.0), "fast", 0.5, averages=4)
    series = []
    for i in range(2000):
        if i % 100 == 0:
            move(25.0 + i / 100)
        lab.clock.advance(0.6)
        frequency = 500.0 if i % 2 else 15000.0
        z = lab.measured_impedance(frequency, "slow", 1.5)
        series.append((z.real, z.imag))
    for i in PINNED_INDICES:
        out.extend(series[i])
    return out


def sweep_experiment(folder: Path) -> Path:
    """A short displacement sweep both ways (settling, two readings per point)."""
    path = folder / "sweep.yaml"
    path.write_text(yaml.safe_dump({
        "kind": "displacement_sweep", "name": "pinned", "home_first": True,
        "bridge": {"function": "L-R", "circuit": "series", "voltage_v": 1.5, "speed": "slow"},
        "sweep": {"positions_mm": [20.0, 35.0, 50.0], "frequencies_hz": [500, 15000], "direction": "both",
                  "readings_per_point": 2, "settle_s": 1.0}}))
    return path


# Computed on main 699995a: [float(v) for v in lab_scenario(station)].
PINNED_LAB = {
    'simulated_lab.yaml': (
        50.21497288286759, 167.91313801250664, 105.21526685756643, 5189.378535705291,
        50379.25834403143, -37266.68123264902, 105.0044334926818, 5189.482768060098,
        22.0, 22.0, 50.635798265781645, 167.92626795123962,
        105.21197729474423, 5188.262340131343, 51329.23415323827, -37247.50276097124,
        105.14782606640443, 5188.624666232799, 25.949410667324653, 33.07753735157074,
        50.6444004093283, 167.7986280147329, 106.80846526042197, 5181.161009542004,
        50.61830339668966, 67.1011965892363, 105.10190941333035, 5185.516452374294,
        25.982227609216693, 33.13710175734851, 105.40723717124185, 5185.283653870919,
        50.656437477086364, 167.8215698521587, 105.20263235433342, 5185.238268604641,
        50.899075934597434, 167.8348774640063, 105.00465494823206, 5184.856939373774,
        51.67009602994725, 167.93972811334982,
    ),
    'simulated_lab_steel.yaml': (
        50.337967818231114, 168.14048394789103, 106.61422803402654, 5190.952550491725,
        50362.33568310231, -37258.45747826063, 106.40336619135013, 5191.056851973293,
        22.0, 22.0, 50.76223133227077, 168.16783778951725,
        106.70917574034881, 5189.966563487193, 51310.28911400392, -37238.78111797403,
        106.6451336475156, 5190.329173935927, 25.949410667324653, 30.875927326330935,
        50.80470920117974, 168.1146833276272, 108.78303752123895, 5183.4302778355695,
        50.68518444965519, 67.27200122205517, 107.07589081417046, 5187.787876655624,
        25.982227609216693, 30.950475739223485, 107.38172611266762, 5187.555523660877,
        50.81677961975176, 168.13777975322148, 107.17726491056717, 5187.51044287402,
        51.05292133809299, 168.13928253547405, 106.71010453600991, 5186.820849895071,
        51.791683252219684, 168.17672416859006,
    ),
    'ecm': (
        50.54470115516826, 179.02730991782394, 84.96762463241129, 5490.591532107226,
        231279.54363041857, -406638.6224289144, 84.93133344551661, 5490.734655037593,
        22.0, 22.0, 51.30306941613523, 179.04440001222122,
        85.92306093749642, 5491.207086599348, 231024.00023671243, -406319.8368789358,
        85.74363525220207, 5491.062020390219, 25.949410667324653, 33.39800578027845,
        51.30699125128486, 179.01631317742172, 85.26094581551081, 5488.815992612643,
        51.19660184511877, 71.61649255171571, 86.05554224653085, 5487.830270199712,
        25.982227609216693, 33.45606658314421, 85.9730098608276, 5487.80337363641,
        51.35346190222458, 179.02446090671341, 86.20240859359237, 5487.942729065645,
        51.58333029644868, 179.0286329127704, 86.4187784237867, 5490.371865519999,
        52.13572803089782, 179.04491307189366,
    ),
}

# Computed on main 699995a: the sweep_experiment run on the default station (simulated_lab.yaml), its columns
# as read_run returns them, and per role the event count and SHA-256 of the lines f"{float(clock_s)!r} {kind} {text}"
# (the events of main's per-role layout and of the transcript log are the same, line for line).
PINNED_COLUMNS = {
    'time_s': (
        23.55721359549996, 24.15721359549996, 25.15721359549996, 26.057213595499963,
        30.867213595499962, 31.467213595499963, 32.46721359549998, 33.36721359549998,
        38.177213595499985, 38.77721359549999, 39.7772135955, 40.67721359550001,
        41.677213595500014, 42.27721359550002, 43.577213595500034, 44.177213595500035,
        49.494427191, 50.094427191, 51.094427191000015, 51.99442719100002,
        57.311640786499986, 57.91164078649999, 58.9116407865, 59.81164078650001,
    ),
    'x_readback_mm': (
        20.0, 20.0, 20.0, 20.0,
        35.0, 35.0, 35.0, 35.0,
        50.0, 50.0, 50.0, 50.0,
        50.0, 50.0, 50.0, 50.0,
        35.0, 35.0, 35.0, 35.0,
        20.0, 20.0, 20.0, 20.0,
    ),
    't_coil_c': (
        21.9892609, 21.9892609, 21.9892609, 21.9843618,
        21.9622197, 21.9622197, 21.9622197, 21.9670385,
        21.9980346, 21.9980346, 21.9980346, 22.0182893,
        22.0182893, 22.0182893, 21.9670243, 21.9670243,
        21.9910834, 21.9910834, 21.9910834, 22.0051297,
        22.0066563, 22.0066563, 22.0066563, 22.0028851,
    ),
    't_target_c': (
        22.0116224, 22.0116224, 22.0116224, 21.9948562,
        21.9965046, 21.9965046, 21.9965046, 22.0033493,
        22.0019097, 22.0019097, 22.0019097, 21.9995987,
        21.9995987, 21.9995987, 22.0050878, 22.0050878,
        22.0155065, 22.0155065, 22.0155065, 21.9981034,
        21.9869744, 21.9869744, 21.9869744, 21.9961718,
    ),
    'ls_h': (
        0.0411693, 0.0411685, 0.0413188, 0.041319,
        0.0472807, 0.0472798, 0.0481982, 0.0481989,
        0.0500649, 0.0500657, 0.051314, 0.0513153,
        0.0500651, 0.0500638, 0.0513148, 0.051314,
        0.0472796, 0.0472799, 0.0481997, 0.0482005,
        0.0411606, 0.0411612, 0.0413095, 0.0413099,
    ),
    'rs_ohm': (
        52.8658, 52.8705, 99.3414, 99.4194,
        51.3483, 51.3447, 100.058, 100.178,
        50.7549, 50.7555, 101.745, 101.685,
        50.7562, 50.7539, 101.687, 101.7,
        51.3425, 51.3382, 100.181, 100.165,
        52.8714, 52.8715, 99.4083, 99.4883,
    ),
}
# The bridge's digest was re-pinned once, for a protocol fact from the manual (R&S HM8118 manual, ch. 10, p. 71):
# XALL?'s bin is 99 without the binning interface, where the emulator had answered 0. With each ',99' of its
# replies read back as ',0', the new traffic gives the digest of 699995a (1f463f76...), so nothing else changed.
PINNED_TRANSCRIPTS = {
    'bridge': (152, 'c4c622d98dadfa356e89a0e15d75ad39cb72af4b4f6bd28eca82c866e3b660af'),
    'heater': (23, '96ff8b606330896fd5bca7e17125c6bb196e5045d3c0349f97cb3c95e4209205'),
    'scanner': (31, '2a5f13133721c4bee1aa11199fbf2086a8ce5283f4011ff95d13c0839bef3bfa'),
    'slide': (63, 'ff52e534c33690b7e330da3bec3c8d9045d818821b6236644d5d238d831fe25f'),
}


@pytest.mark.parametrize("station", sorted(PINNED_LAB))
def test_lab_readings_are_the_pinned_ones(station):
    """Moves, heaters, speeds and 2,000 noisy readings give the numbers of the reference implementation."""
    np.testing.assert_allclose(lab_scenario(station), PINNED_LAB[station], rtol=1e-12, atol=0)


def _digest(events) -> str:
    return hashlib.sha256("\n".join(f"{float(e.clock_s)!r} {e.kind} {e.text}" for e in events).encode()).hexdigest()


def test_a_run_through_the_station_gives_the_pinned_rows_and_transcripts(tmp_path):
    """Drivers, transports, emulators and the lab together: the same rows and the same traffic, event for event."""
    result = run_experiment(sweep_experiment(tmp_path), None, tmp_path / "run.h5", progress=False)
    assert result.status == "completed"
    run = read_run(tmp_path / "run.h5")
    for column, values in PINNED_COLUMNS.items():
        np.testing.assert_allclose(run.column(column), values, rtol=1e-12, atol=0, err_msg=column)
    assert {role: (len(events), _digest(events)) for role, events in run.transcripts.items()} == PINNED_TRANSCRIPTS
