"""The IdentifyPlant step: a small power pulse of one heater, its thermocouple followed until the response
turns, a FOPDT fit and the PI gains it proposes (:mod:`ecds_lab.runner.plant_identification`).

Safety: the pulse is a fraction of the heater's power and ends once the thermocouple has risen ``rise_k`` or
comes within ``margin_k`` of its over-temperature limit; every reading passes the interlocks; the heater is
off when the step ends. A plant that does not answer within ``timeout_s`` fails the run, naming the heater.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from ecds_lab.errors import EcdsLabError
from ecds_lab.runner.context import RunContext
from ecds_lab.runner.heater_control import HeaterGoal
from ecds_lab.runner.plant_identification import fit_pulse, simc_gains
from ecds_lab.runner.steps import IdentifyPlant

log = logging.getLogger("ecds_lab.runner")

#: A fitted time constant this long means the record only showed the initial slope (a day).
MAX_CREDIBLE_TAU_S = 86400.0
#: Readings before the pulse (the baseline and its drift).
BASELINE_READINGS = 4
#: After the pulse the record ends once the rise fell to this fraction of its peak ...
FALLEN_TO = 0.75
#: ... or this many pulse lengths after the pulse ended.
RECORD_AFTER_PULSES = 3.0


def identify(run: RunContext, step: IdentifyPlant) -> None:
    """Pulse, follow, fit; the proposed gains become the heater's for the rest of the run."""
    heater, period = step.heater, step.check_interval_s
    heaters = run.heaters
    limit_c = run.station.config.safety.max_temperature_c.get(heater, math.inf) - step.margin_k
    power_w = step.step_fraction * heaters.max_power_w[heater]
    start = run.clock.now()
    times: list[float] = []
    temps: list[float] = []

    def sample() -> float:
        if run.clock.now() - start > step.timeout_s:
            heaters.set_goal(heater, HeaterGoal(), temperatures=dict)
            raise EcdsLabError(f"{heater} heater identification: no usable response after {step.timeout_s:g} s "
                               f"(a {power_w:.1f} W step; rise so far {temps[-1] - temps[0]:+.2f} K)")
        temperatures = run.thermocouples.read(fresh=True)
        if heaters.regulating:
            heaters.control(temperatures)  # another heater holding a setpoint keeps being regulated
        times.append(run.clock.now())
        temps.append(temperatures[heater])
        run.progress.note(f"identifying {heater}: {temperatures[heater]:.1f} C")
        return temperatures[heater]

    heaters.set_goal(heater, HeaterGoal(), temperatures=dict)
    for _ in range(BASELINE_READINGS):
        sample()
        run.clock.sleep(period)
    baseline_c = float(np.mean(temps))
    on_s = run.clock.now()
    heaters.set_goal(heater, HeaterGoal(power_w=power_w), temperatures=dict)
    while True:
        run.clock.sleep(period)
        value = sample()
        if value - baseline_c >= step.rise_k or value >= limit_c:
            break
    off_s = run.clock.now()
    heaters.set_goal(heater, HeaterGoal(), temperatures=dict)
    peak = max(temps) - baseline_c
    while run.clock.now() - off_s < RECORD_AFTER_PULSES * (off_s - on_s):
        run.clock.sleep(period)
        value = sample()
        peak = max(peak, value - baseline_c)
        if value - baseline_c < FALLEN_TO * peak:
            break
    plant = fit_pulse(np.array(times) - start, np.array(temps), on_s=on_s - start, off_s=off_s - start,
                      power_w=power_w)
    gains = simc_gains(plant, period_s=period, max_power_w=heaters.max_power_w[heater])
    heaters.gains[heater] = gains
    if plant.tau_s < MAX_CREDIBLE_TAU_S:  # an integrating fit (tau at its bound) says nothing of the steady gain
        heaters.plant_gain_k_per_w[heater] = plant.gain_k_per_w
    run.identified[heater] = {"step_w": power_w, "baseline_c": baseline_c, "peak_c": max(temps),
                              "gain_k_per_w": plant.gain_k_per_w, "tau_s": plant.tau_s,
                              "lag_s": plant.lag_s, "dead_time_s": plant.dead_time_s, "kp_w_per_k": gains.kp_w_per_k,
                              "ti_s": gains.ti_s, "td_s": gains.td_s}
    station_gains = getattr(run.station.config.regulation, heater)
    note = (f"{heater} heater identified: {plant.gain_k_per_w:.3g} K/W, time constants {plant.tau_s:.0f} s and "
            f"{plant.lag_s:.0f} s, dead time {plant.dead_time_s:.0f} s -> gains Kp {gains.kp_w_per_k:.3g} W/K, "
            f"Ti {gains.ti_s:.0f} s, Td {gains.td_s:.0f} s (station: Kp {station_gains.kp_w_per_k:g} W/K, "
            f"Ti {station_gains.ti_s:g} s, Td {station_gains.td_s:g} s)")
    log.info("%s", note)
    run.notes.append(note)
