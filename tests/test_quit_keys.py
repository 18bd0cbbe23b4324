"""q and Ctrl-C quit every terminal view (issue 32, defect 7: Textual's Ctrl-C only hinted at
ctrl+q): the monitor and teleop here, the dashboard in tests/dashboard/test_app.py."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import can
import pytest
from textual.app import App

from bywire.monitor.app import MonitorApp
from bywire.monitor.bus_reader import CanFeed
from bywire.monitor.bus_state import BusModel
from bywire.teleop.app import TeleopApp


@pytest.fixture
def bus() -> Iterator[can.BusABC]:
    with can.Bus(interface="virtual", channel="quit-keys", receive_own_messages=False) as opened:
        yield opened


def _still_running_after(app: App[None], key: str) -> bool:
    async def press() -> bool:
        async with app.run_test() as pilot:
            await pilot.press(key)
            await pilot.pause()
            return app.is_running

    return asyncio.run(press())


@pytest.mark.parametrize("key", ["q", "ctrl+c"])
def test_the_monitor_quits(bus: can.BusABC, key: str) -> None:
    app = MonitorApp(CanFeed(bus), BusModel(), "virtual")
    assert _still_running_after(app, key) is False


@pytest.mark.parametrize("key", ["q", "ctrl+c"])
def test_teleop_quits_and_sends_its_full_brake_first(bus: can.BusABC, key: str) -> None:
    app = TeleopApp(bus, auto_tick=False)
    assert _still_running_after(app, key) is False
    assert app.frames_sent == 3  # the one period of full brake on the way out
