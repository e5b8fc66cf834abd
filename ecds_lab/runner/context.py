"""What step handlers work with during a run: the station, its tracked state, and the run file."""

from __future__ import annotations

import logging
import time

from ecds_lab.clock import Clock
from ecds_lab.data.columns import LOGGED_POINT
from ecds_lab.runner.heaters import Heaters
from ecds_lab.runner.interlocks import GuardedThermocouples
from ecds_lab.runner.progress import Progress
from ecds_lab.runner.rows import reading_row
from ecds_lab.runner.slide_position import SlidePosition
from ecds_lab.runner.steps import MeasurePoint
from ecds_lab.runner.temperature_hold import HoldRecord, HoldTracker
from ecds_lab.station import Station
from ecds_lab.storage.run_file import RunWriter

log = logging.getLogger("ecds_lab.runner")

#: Temperatures and heater powers older than this (simulated or wall seconds) are read again.
READING_MAX_AGE_S = 2.0
#: A sleep's remainder shorter than this is not slept (a clock's float sum need not reach the end exactly).
_SLEEP_RESOLUTION_S = 1e-6


class RunContext:
    """The station and run file of one run, with the slide position, heaters and thermocouples it tracks."""

    def __init__(self, station: Station, writer: RunWriter, progress: Progress, *, t0: float,
                 heats: bool, coil_in_air: bool) -> None:
        self.station = station
        self.writer = writer
        self.progress = progress
        self.clock: Clock = station.clock
        self.t0 = t0
        self.coil_in_air = coil_in_air
        self.step_index = -1
        self.position = SlidePosition(station.slide)
        config = station.config
        self.heaters = Heaters(station.heater, self.clock, config.heaters, config.safety, read_back=heats,
                               max_age_s=READING_MAX_AGE_S, regulation=config.regulation)
        self.thermocouples = GuardedThermocouples(station.scanner, self.clock, config.safety.max_temperature_c,
                                                  heating=lambda: self.heaters.heating, max_age_s=READING_MAX_AGE_S)
        #: Per heater: how it holds its setpoint since it was steady there (closed by a CheckHold step).
        self.holding: dict[str, HoldTracker] = {}
        #: The closed holds, in order, and the heaters' identified plants and gains: recorded in the run file.
        self.holds: list[HoldRecord] = []
        self.identified: dict[str, dict[str, float]] = {}
        #: What the operator should read at the end of the run (identified gains, holds out of tolerance).
        self.notes: list[str] = []

    def tend_heaters(self, *, due: bool = False) -> None:
        """Run the heater loops if a control period has passed (or the caller knows it has: ``due``); between
        readings, moves and settling a heater holding a setpoint is regulated as in a wait. Nothing while no heater
        holds a temperature."""
        if (due and self.heaters.regulating) or self.heaters.control_due():
            temperatures = self.thermocouples.read(fresh=True)
            self.heaters.control(temperatures)
            self.observe_holds(temperatures)

    def sleep(self, seconds: float) -> None:
        """Sleep ``seconds`` of lab time, running the heater loops each period meanwhile."""
        end = self.clock.now() + seconds
        while (left := end - self.clock.now()) > _SLEEP_RESOLUTION_S:
            wait = self.heaters.seconds_to_next_control()
            if wait > _SLEEP_RESOLUTION_S:
                self.clock.sleep(min(left, wait))
            if wait <= left:
                self.tend_heaters(due=True)

    def observe_holds(self, temperatures: dict[str, float]) -> None:
        """Feed a reading of the thermocouples to every hold in progress."""
        if self.holding:
            now = self.clock.now() - self.t0
            for tracker in self.holding.values():
                tracker.observe(now, temperatures)
    def record(self, freq_hz: float, kind: int, point: MeasurePoint | None = None) -> None:
        """One bridge reading with the temperatures and heater powers of the moment, appended to the run file."""
        bridge = self.station.bridge
        bridge.set_frequency(freq_hz)
        reading = bridge.measure()
        temperatures = self.thermocouples.read()
        self.observe_holds(temperatures)
        powers = self.heaters.powers()
        self.writer.append_row(reading_row(
            time_s=self.clock.now() - self.t0, wall_time_s=time.time(), step_index=self.step_index, kind=kind,
            point=point, position=self.position, in_air=point.in_air if point is not None else self.coil_in_air,
            freq_hz=freq_hz, temperatures=temperatures, powers_w=powers, reading=reading))

    def log_readings(self, frequencies_hz: tuple[float, ...]) -> None:
        """Unplanned bridge readings (while waiting on a heater), one per frequency."""
        for freq in frequencies_hz:
            self.record(freq, LOGGED_POINT)
