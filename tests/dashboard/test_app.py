"""Headless textual pilot: the dashboard of a simulated robot, from a finished virtual-time run
(exact content) and live, in real time on a background thread (mode changes, flags, clean stop)."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

from textual.pilot import Pilot
from textual.widgets import DataTable, Static

from bywire.config import default_sim_config
from bywire.dashboard.app import DashboardApp
from bywire.dashboard.feed import SnapshotFeed
from bywire.dashboard.live import LiveRun
from bywire.runtime.schedule import SCHEDULE
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun
from tests.system.harness import Robot

SIZE = (160, 50)
TIMEOUT_S = 10.0
# Short, so the real-time test takes about a second: arm, drive by RC, unplug the receiver.
QUICK_LINK_LOSS = """
name = "quick-link-loss"
description = "RC, then the receiver unplugged"
duration_s = 1.6
[[event]]
at_s = 0.1
rc = { mode = "stop", gear = "forward", throttle = 0.0 }
[[event]]
at_s = 0.2
rc = { mode = "rc" }
[[event]]
at_s = 0.9
fault = "rc_link_lost"
"""


def _panel(app: DashboardApp, name: str) -> str:
    return str(app.query_one(f"#{name}", Static).content)


def _rows(app: DashboardApp) -> dict[str, list[str]]:
    table: DataTable[str] = app.query_one(DataTable)
    rows = {}
    for key in table.rows:
        cells = [str(cell) for cell in table.get_row(key)]
        rows[cells[0]] = cells
    return rows


def test_the_panels_and_the_task_table_show_a_snapshot() -> None:
    robot = Robot.build()
    robot.arm_rc()
    feed = SnapshotFeed(robot.runtime, wall_clock=robot.clock.now).attach()
    robot.run(1.0)
    feed.observe(robot.clock.now(), force=True)  # as the live run does at its end
    app = DashboardApp(feed, source="virtual")

    async def look() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await pilot.pause()
            assert "mode RC  armed" in _panel(app, "mode")
            assert "error flags: none" in _panel(app, "mode")
            assert "source   RC transmitter (IBUS)" in _panel(app, "commands")
            assert "e-brake released" in _panel(app, "actuators")
            assert "IBUS " in _panel(app, "inputs")
            rows = _rows(app)
            assert list(rows) == [*(spec.name for spec in SCHEDULE), "idle"]
            assert rows["steering"][1:3] == ["100.0 Hz", "100 Hz"]
            assert rows["lights"][1:3] == ["20.0 Hz", "20 Hz"]
            assert rows["idle"][3].endswith(" %")

    asyncio.run(look())


async def _until(pilot: Pilot[None], app: DashboardApp, text: str) -> str:
    """Wait (generously) until the mode panel shows `text`; return the panel."""
    deadline = time.monotonic() + TIMEOUT_S
    while text not in (panel := _panel(app, "mode")):
        assert time.monotonic() < deadline, f"never shown: {text!r}; last: {panel!r}"
        await pilot.pause(0.05)
    return panel


def test_the_live_dashboard_follows_the_controller_and_q_stops_it(tmp_path: Path) -> None:
    scenario_file = tmp_path / "quick.toml"
    scenario_file.write_text(QUICK_LINK_LOSS, encoding="utf-8")
    sim = SimRun(default_sim_config(), find_scenario(str(scenario_file)), realtime=True)
    live = LiveRun(sim)
    app = DashboardApp(live.feed, source="quick", on_exit=live.stop)

    async def watch() -> str:
        async with app.run_test(size=SIZE) as pilot:
            live.start()
            await _until(pilot, app, "mode RC  armed")
            panel = await _until(pilot, app, "RC_TIMEOUT")
            assert "mode STOP  LATCHED" in panel
            assert set(_rows(app)) == {*(spec.name for spec in SCHEDULE), "idle"}
            await pilot.press("q")
            return panel

    try:
        asyncio.run(watch())
        assert not live.running  # q stopped the controller (or the short scenario had ended)
    finally:
        live.stop()
    motors = sim.world.gpio["motors_enable"].history
    ebrake = sim.world.gpio["ebrake_release"].history
    assert motors[-1][1] is False
    assert ebrake[-1][1] is False
    assert live.feed.status is not None
    assert live.error is None


def test_q_stops_a_long_run_at_once_with_safe_outputs() -> None:
    sim = SimRun(default_sim_config(), find_scenario("test-course"), realtime=True)
    live = LiveRun(sim)
    app = DashboardApp(live.feed, on_exit=live.stop)

    async def quit_soon() -> None:
        async with app.run_test(size=SIZE) as pilot:
            live.start()
            await _until(pilot, app, "mode STOP")
            await pilot.press("q")

    try:
        asyncio.run(quit_soon())
        assert not live.running
    finally:
        live.stop()
    assert live.feed.status == "stopped: outputs safe"
    assert sim.world.clock.now() - sim.started_at < sim.duration_s
    assert sim.world.gpio["motors_enable"].history[-1][1] is False
