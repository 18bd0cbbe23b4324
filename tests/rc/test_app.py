"""The live view, headless (textual's pilot), on the simulated transmitter in real time."""

from __future__ import annotations

import asyncio
import time

import pytest
from textual.widgets import DataTable, Static

from bywire.config import RobotConfig
from bywire.rc.app import RcApp
from bywire.rc.ibus_reading import RcSession
from bywire.rc.sweep import SweepSource

TIMEOUT_S = 10.0


def _app() -> RcApp:
    config = RobotConfig()
    source = SweepSource(config.rc.mapping, 1.0, paced=True)
    return RcApp(source, RcSession(config), lambda suggestion: f"{len(suggestion.items)} items")


def test_the_view_shows_every_channel_what_it_reads_as_and_starts_over_on_r() -> None:
    app = _app()

    async def watch() -> tuple[list[str], int, int, str]:
        async with app.run_test(size=(200, 40)) as pilot:
            deadline = time.monotonic() + TIMEOUT_S
            while app.session.seen.frames < 50:
                assert time.monotonic() < deadline, "no frames from the simulated receiver"
                await pilot.pause(0.1)
            table = app.query_one(DataTable)
            mode = [
                str(cell) for cell in table.get_row(str(app.session.mapping.mode_switch.channel))
            ]
            before = app.session.seen.frames
            await pilot.press("r")
            forgotten = app.session.parser.stats.frames - app.session.seen.frames
            shown = str(app.query_one("#suggestion", Static).render())
            await pilot.press("q")
            return mode, before, forgotten, shown

    mode, before, forgotten, shown = asyncio.run(watch())
    assert mode[:3] == ["6", "CH7", "mode switch"]
    assert mode[3] == "1000"
    assert mode[6] == "STOP"
    assert forgotten >= before  # r forgot what was seen; the parser's counters went on
    assert shown == "6 items"


@pytest.mark.parametrize("key", ["q", "ctrl+c"])
def test_the_view_quits(key: str) -> None:
    app = _app()

    async def press() -> bool:
        async with app.run_test() as pilot:
            await pilot.press(key)
            await pilot.pause()
            return app.is_running

    assert asyncio.run(press()) is False
