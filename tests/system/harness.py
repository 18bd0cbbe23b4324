"""A whole robot for system tests: the real controller on the simulated robot, on virtual time."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode, Gear
from bywire.runtime.loop import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.runtime.watchdog import POLL_S as WATCHDOG_POLL_S

THROTTLE_CHANNEL = 0
REGEN_CHANNEL = 1


def volts_at(history: list[tuple[float, int, float]], wanted: int, time_s: float) -> float:
    """The volts DAC channel `wanted` drove at `time_s`, from the DAC's change history."""
    volts = 0.0
    for stamp_s, channel, value in history:
        if stamp_s > time_s:
            break
        if channel == wanted:
            volts = value
    return volts


@dataclass
class Robot:
    """World, controller and a timeline of actions; `run` plays it once, then read the histories."""

    clock: VirtualClock
    world: SimWorld
    runtime: Runtime

    @classmethod
    def build(cls, config: RuntimeConfig | None = None) -> Robot:
        """The watchdog on the virtual clock, checked as the simulator checks it: its own
        thread measures the wall clock, where a test process that waited for a turn on a busy
        machine tripped it (the dashboard's speed-limit state read STOP beside a compiled
        build, 2026-12-07)."""
        clock = VirtualClock()
        world = SimWorld.create(clock)
        runtime = Runtime(world.hardware, config or RuntimeConfig(), watchdog_thread=False)
        watchdog = runtime.watchdog
        if watchdog is not None:

            def check(_tick_s: float) -> None:
                watchdog.check()

            PeriodicTimer(clock, WATCHDOG_POLL_S, check).start()
        return cls(clock, world, runtime)

    def at(self, time_s: float, action: Callable[[], None]) -> None:
        self.clock.call_at(time_s, action)

    def arm_rc(self, at_s: float = 0.1) -> None:
        """Switch through STOP into RC, forward gear, sticks centred."""
        rc = self.world.rc

        def switch_to_stop_in_forward() -> None:
            rc.set_mode(ControlMode.STOP)
            rc.set_gear(Gear.FORWARD)

        self.at(at_s, switch_to_stop_in_forward)
        self.at(at_s + 0.1, lambda: rc.set_mode(ControlMode.RC))

    def run(self, until_s: float) -> None:
        self.world.start()
        self.runtime.run(until_s=until_s)

    # --- reading the outputs as they were ------------------------------------------------------

    def level(self, line: str, time_s: float) -> bool:
        return self.world.gpio[line].level_at(time_s)

    def throttle_volts(self, time_s: float) -> float:
        return self._dac_volts(THROTTLE_CHANNEL, time_s)

    def regen_volts(self, time_s: float) -> float:
        return self._dac_volts(REGEN_CHANNEL, time_s)

    def _dac_volts(self, wanted: int, time_s: float) -> float:
        return volts_at(self.world.dac.history, wanted, time_s)

    def first_time(self, after_s: float, condition: Callable[[float], bool]) -> float | None:
        """Earliest change time ≥ after_s at which `condition(time)` holds (every output change)."""
        times = sorted(
            {stamp for history in self._histories() for stamp in history if stamp >= after_s}
        )
        return next((stamp for stamp in [after_s, *times] if condition(stamp)), None)

    def safe_at(self, time_s: float) -> bool:
        """Stopping: e-brake engaged, throttle at 0 V, and the drive off or (a controlled stop,
        category 1) braking with the regenerative brake."""
        return (
            not self.level("ebrake_release", time_s)
            and self.throttle_volts(time_s) == 0.0
            and (not self.level("motors_enable", time_s) or self.regen_volts(time_s) > 0.0)
        )

    def off_at(self, time_s: float) -> bool:
        """The drive's power removed: enable low, e-brake engaged, throttle at 0 V."""
        return (
            not self.level("ebrake_release", time_s)
            and not self.level("motors_enable", time_s)
            and self.throttle_volts(time_s) == 0.0
        )

    def rising_edges(self, line: str) -> list[float]:
        history = self.world.gpio[line].history
        return [stamp for stamp, level in history if level]

    def _histories(self) -> list[list[float]]:
        lines = [[stamp for stamp, _ in out.history] for out in self.world.gpio.values()]
        return [*lines, [stamp for stamp, _, _ in self.world.dac.history]]
