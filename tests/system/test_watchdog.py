"""R-WATCHDOG on the real-time simulated robot: a stalled loop is made safe from outside it."""

from __future__ import annotations

import threading
from dataclasses import replace

from bywire.control.error_flags import ErrorFlag
from bywire.control.supervisor import Cause
from bywire.hal.sim.clock import RealtimeClock
from bywire.hal.sim.world import SimWorld
from bywire.model import ControlMode, Gear
from bywire.runtime.app import Runtime
from bywire.runtime.settings import RuntimeConfig


def test_a_stalled_loop_gets_safe_outputs_and_a_latched_stop() -> None:
    clock = RealtimeClock()
    world = SimWorld.create(clock)
    runtime = Runtime(world.hardware, replace(RuntimeConfig(), watchdog_s=0.05))
    start_s = clock.now()
    rc = world.rc

    def switch_to_stop_in_forward() -> None:
        rc.set_mode(ControlMode.STOP)
        rc.set_gear(Gear.FORWARD)

    clock.call_at(start_s + 0.05, switch_to_stop_in_forward)
    clock.call_at(start_s + 0.15, lambda: rc.set_mode(ControlMode.RC))
    clock.call_at(start_s + 0.20, lambda: rc.set_pedal(0.5))
    stalled = threading.Event()
    enable_during_stall: list[bool] = []

    def stall_once(now: float) -> None:
        watchdog = runtime.watchdog
        if now - start_s < 0.5 or stalled.is_set() or watchdog is None:
            return
        stalled.set()
        assert world.gpio["motors_enable"].level  # driving when the loop freezes
        for _ in range(1000):  # the loop is stuck here until the watchdog has acted
            if watchdog.tripped:
                break
            threading.Event().wait(0.01)
        enable_during_stall.append(world.gpio["motors_enable"].level)

    runtime.on_cycle.append(stall_once)
    world.start()
    runtime.run(until_s=start_s + 0.8)
    assert stalled.is_set()
    assert enable_during_stall == [False]  # the watchdog's thread disabled the motors
    assert runtime.watchdog is not None
    assert runtime.watchdog.trips == 1
    outputs = runtime.outputs
    assert outputs is not None
    assert outputs.mode is ControlMode.STOP
    assert outputs.causes == {Cause.WATCHDOG}
    assert outputs.error_flags & ErrorFlag.WATCHDOG_TRIPPED
