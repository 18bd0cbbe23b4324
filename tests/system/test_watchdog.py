"""R-WATCHDOG on the simulated robot: a stalled loop is made safe from outside it, by a thread.

The robot runs on virtual time, and the watchdog is the real one with its own thread. Its time
stands still until the test freezes the loop, and from then on it is the wall clock. The host
stalls this VM's processes for hundreds of milliseconds now and then; on the wall clock from the
start, a 50 ms watchdog tripped on those stalls, before the test's own, in CI. So here only the
stall under test can trip it, and the thread still has to act while the loop is stuck.
"""

from __future__ import annotations

import threading
import time

from bywire.control.supervisor import Cause
from bywire.error_flags import ErrorFlag
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.world import SimWorld
from bywire.model import ControlMode, Gear
from bywire.runtime.loop import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.runtime.watchdog import Watchdog

LIMIT_S = 0.05


class StallTime:
    """The watchdog's monotonic time: 0 until `start`, then wall-clock seconds since it."""

    def __init__(self) -> None:
        self.started_s: float | None = None

    def start(self) -> None:
        self.started_s = time.monotonic()

    def __call__(self) -> float:
        return 0.0 if self.started_s is None else time.monotonic() - self.started_s


def test_a_stalled_loop_gets_safe_outputs_and_a_latched_stop() -> None:
    clock = VirtualClock()
    world = SimWorld.create(clock)
    runtime = Runtime(world.hardware, RuntimeConfig(), watchdog_thread=True)
    stall_time = StallTime()
    watchdog = runtime.watchdog = Watchdog(
        runtime.actuators.watchdog_trip, LIMIT_S, monotonic=stall_time
    )
    rc = world.rc

    def switch_to_stop_in_forward() -> None:
        rc.set_mode(ControlMode.STOP)
        rc.set_gear(Gear.FORWARD)

    clock.call_at(0.05, switch_to_stop_in_forward)
    clock.call_at(0.15, lambda: rc.set_mode(ControlMode.RC))
    clock.call_at(0.20, lambda: rc.set_pedal(0.5))
    stalled = threading.Event()
    enable_during_stall: list[bool] = []
    wall_s: list[float] = []

    def stall_once(now: float) -> None:
        if now < 0.5 or stalled.is_set():
            return
        stalled.set()
        assert world.gpio["motors_enable"].level  # driving when the loop freezes
        assert not watchdog.tripped
        stall_time.start()
        for _ in range(1000):  # the loop is stuck here until the watchdog has acted
            if watchdog.tripped:
                break
            threading.Event().wait(0.01)
        wall_s.append(stall_time())
        enable_during_stall.append(world.gpio["motors_enable"].level)

    runtime.on_cycle.append(stall_once)
    world.start()
    runtime.run(until_s=0.8)
    assert stalled.is_set()
    assert wall_s[0] > LIMIT_S  # not before the limit
    assert enable_during_stall == [False]  # the watchdog's thread disabled the motors
    assert watchdog.trips == 1  # and it stays latched: no reset, so no second trip
    outputs = runtime.outputs
    assert outputs is not None
    assert outputs.mode is ControlMode.STOP
    assert outputs.causes == {Cause.WATCHDOG}
    assert outputs.error_flags & ErrorFlag.WATCHDOG_TRIPPED
