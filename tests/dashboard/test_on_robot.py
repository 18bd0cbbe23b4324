"""`bywire run --dashboard`'s runner: the controller in its own thread under the live view.

The "robot" is the simulated one on a real-time clock (the loop paces itself as on the robot).
Textual runs headless; waits are for conditions, with generous limits, never for durations.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Awaitable, Callable

import pytest
from textual.pilot import Pilot
from textual.widgets import DataTable, Static

from bywire.dashboard import feed as feed_module
from bywire.dashboard.on_robot import (
    GuardedObserver,
    RobotDashboardApp,
    RobotRun,
    held_logs,
    run_with_dashboard,
)
from bywire.dashboard.snapshot import DashboardSnapshot
from bywire.errors import HardwareError
from bywire.hal.sim.clock import RealtimeClock
from bywire.hal.sim.world import SimWorld
from bywire.model import ControlMode, Gear
from bywire.runtime.app import Runtime
from bywire.runtime.schedule import SCHEDULE
from bywire.runtime.settings import RuntimeConfig
from tests.system.harness import Robot

SIZE = (160, 50)
TIMEOUT_S = 10.0


class StandIn:
    """A robot for the runner: the simulated world on the wall clock, armed into RC at 0.1 s."""

    def __init__(self) -> None:
        self.clock = RealtimeClock()
        self.world = SimWorld.create(self.clock)
        self.runtime = Runtime(self.world.hardware, RuntimeConfig())
        rc = self.world.rc

        def switch_to_stop_in_forward() -> None:
            rc.set_mode(ControlMode.STOP)
            rc.set_gear(Gear.FORWARD)

        self.clock.call_at(0.1, switch_to_stop_in_forward)
        self.clock.call_at(0.2, lambda: rc.set_mode(ControlMode.RC))
        self.world.start()

    def assert_safe(self) -> None:
        for line in ("motors_enable", "ebrake_release"):
            assert self.world.gpio[line].history[-1][1] is False, line
        throttle = [volts for _, channel, volts in self.world.dac.history if channel == 0]
        assert throttle[-1] == 0.0


def _mode(app: RobotDashboardApp) -> str:
    return str(app.query_one("#mode", Static).content)


def _rows(app: RobotDashboardApp) -> list[str]:
    table: DataTable[str] = app.query_one(DataTable)
    return [str(table.get_row(key)[0]) for key in table.rows]


async def _until(pilot: Pilot[None], condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + TIMEOUT_S
    while not condition():
        assert time.monotonic() < deadline, f"never: {what}"
        await pilot.pause(0.05)


def _pilot(
    script: Callable[[RobotDashboardApp, Pilot[None]], Awaitable[None]],
) -> Callable[..., None]:
    """A `show` for run_with_dashboard: the app under textual's pilot, running `script`."""

    def show(app: RobotDashboardApp) -> None:
        async def drive() -> None:
            async with app.run_test(size=SIZE) as pilot:
                await script(app, pilot)

        asyncio.run(drive())

    return show


def test_the_view_shows_mode_and_tasks_and_q_stops_the_controller_safe() -> None:
    robot = StandIn()
    seen: list[RobotDashboardApp] = []

    async def script(app: RobotDashboardApp, pilot: Pilot[None]) -> None:
        seen.append(app)
        await _until(pilot, lambda: "mode RC  armed" in _mode(app), "RC armed on screen")
        assert "source   RC transmitter (IBUS)" in str(app.query_one("#commands", Static).content)
        assert _rows(app) == [*(spec.name for spec in SCHEDULE), "idle"]
        assert app.robot.running
        assert app.sub_title == "stand-in"
        await pilot.press("q")

    assert run_with_dashboard(robot.runtime, source="stand-in", show=_pilot(script)) == 0
    (app,) = seen
    assert app.robot.ended
    assert app.robot.error is None
    assert app.robot.feed.status == "stopped: outputs safe"
    assert app.robot.guard.failures == 0
    robot.assert_safe()


def test_a_stop_request_ends_the_controller_and_the_view_quits_by_itself() -> None:
    """What SIGINT/SIGTERM do: the handler only requests the stop; the app sees the end."""
    robot = StandIn()
    stopper = threading.Timer(0.3, robot.runtime.request_stop)

    def show(app: RobotDashboardApp) -> None:
        stopper.start()
        asyncio.run(app.run_async(headless=True, size=SIZE))  # returns when the app quits

    try:
        assert run_with_dashboard(robot.runtime, show=show) == 0
    finally:
        stopper.cancel()
    robot.assert_safe()


def test_a_failing_snapshot_is_shown_and_the_controller_goes_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def broken(*_args: object) -> DashboardSnapshot:
        raise ZeroDivisionError("bug in the view")

    monkeypatch.setattr(feed_module, "snapshot", broken)
    robot = StandIn()
    cycles: list[float] = []

    async def script(app: RobotDashboardApp, pilot: Pilot[None]) -> None:
        robot.runtime.on_cycle.append(cycles.append)  # after the guarded feed
        await _until(pilot, lambda: app.robot.guard.failures >= 3, "three failed snapshots")
        await _until(pilot, lambda: "snapshot failed" in _mode(app), "the failure on screen")
        assert "ZeroDivisionError('bug in the view')" in _mode(app)
        assert "snapshot failed" in app.sub_title
        assert app.robot.running
        await _until(pilot, lambda: robot.runtime.mode_log[-1][1] is ControlMode.RC, "RC mode")
        await pilot.press("q")

    with held_logs():  # the first failure's traceback is logged; keep pytest's output tidy
        assert run_with_dashboard(robot.runtime, show=_pilot(script)) == 0
    assert len(cycles) > 3  # the loop went on after the failures
    robot.assert_safe()


def test_an_observer_that_raises_every_time_never_ends_the_loop() -> None:
    """Virtual time: the loop runs its whole second; the guard retries once per period."""
    robot = Robot.build()
    robot.arm_rc()
    calls: list[float] = []

    def raising(now: float) -> None:
        calls.append(now)
        raise RuntimeError("boom")

    guard = GuardedObserver(raising, retry_s=0.1)
    robot.runtime.on_cycle.append(guard)
    with held_logs():
        robot.run(1.0)
    assert robot.clock.now() >= 1.0
    assert robot.runtime.mode_log[-1][1] is ControlMode.RC
    assert guard.failures == len(calls)
    assert 9 <= guard.failures <= 11
    assert guard.failure is not None
    assert guard.failure.startswith("snapshot failed (")


def test_a_crash_of_the_ui_stops_the_controller_safe() -> None:
    robot = StandIn()
    runs: list[RobotRun] = []

    def crash(app: RobotDashboardApp) -> None:
        runs.append(app.robot)
        deadline = time.monotonic() + TIMEOUT_S
        while app.robot.feed.latest() is None:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        raise RuntimeError("the terminal went away")

    with pytest.raises(RuntimeError, match="terminal went away"):
        run_with_dashboard(robot.runtime, show=crash)
    assert runs[0].ended
    robot.assert_safe()


def test_an_error_in_the_controller_ends_the_view_and_is_raised_again() -> None:
    robot = StandIn()

    def device_fails(now: float) -> None:
        if now > 0.3:
            raise HardwareError("i2c-1: remote I/O error")

    robot.runtime.on_cycle.append(device_fails)

    def show(app: RobotDashboardApp) -> None:
        asyncio.run(app.run_async(headless=True, size=SIZE))

    with pytest.raises(HardwareError, match="remote I/O error"):
        run_with_dashboard(robot.runtime, show=show)
    robot.assert_safe()
