"""Headless textual pilot at 80×24: the dashboard of real state messages of a simulated robot,
every panel and every task row on screen, the speed shown, the feed's end kept on screen."""

from __future__ import annotations

import asyncio
from typing import Any

from textual.widgets import DataTable, Static

from bywire.dashboard.app import DashboardApp
from bywire.task_table import SCHEDULE
from tests.dashboard.states import driving_by_rc

SIZE = (80, 24)


class Feed:
    """A feed that holds one state message (what the Foxglove client hands the view)."""

    def __init__(self, state: dict[str, Any] | None, status: str = "live") -> None:
        self.state, self.status = state, status

    def latest(self) -> dict[str, Any] | None:
        return self.state


def _panel(app: DashboardApp, name: str) -> str:
    return str(app.query_one(f"#{name}", Static).content)


def _rows(app: DashboardApp) -> dict[str, list[str]]:
    table: DataTable[str] = app.query_one(DataTable)
    return {str(table.get_row(key)[0]): [str(c) for c in table.get_row(key)] for key in table.rows}


def test_at_80_by_24_every_panel_and_task_row_is_on_screen_with_the_speed() -> None:
    app = DashboardApp(Feed(driving_by_rc()), source="test")

    async def look() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await pilot.pause()
            assert "mode RC  armed" in _panel(app, "mode")
            assert "speed " in _panel(app, "mode")
            assert "source RC transmitter" in _panel(app, "commands")
            assert "e-brake released" in _panel(app, "actuators")
            assert "RC age" in _panel(app, "inputs")
            rows = _rows(app)
            assert list(rows) == [*(spec.name for spec in SCHEDULE), "idle"]
            screen = app.screen.region
            assert _panel(app, "flags") == "error flags: none"
            for widget in [*app.query(".panel"), app.query_one("#flags"), app.query_one(DataTable)]:
                assert screen.contains_region(widget.region), (widget.id, widget.region)
            table = app.query_one(DataTable)
            # The whole table is shown: header, six rows, the border; nothing scrolled away.
            assert table.region.height >= len(rows) + 3
            assert table.virtual_size.width <= table.region.width
            assert table.region.bottom <= SIZE[1] - 1  # the footer's line stays free

    asyncio.run(look())


def test_before_the_first_state_it_waits_and_says_where_it_looks() -> None:
    app = DashboardApp(Feed(None, "connecting to ws://127.0.0.1:1"), source="test")

    async def look() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await pilot.pause()
            assert "waiting for the feed" in _panel(app, "mode")
            assert "connecting to ws://127.0.0.1:1" in app.sub_title

    asyncio.run(look())


def test_q_quits_the_view() -> None:
    app = DashboardApp(Feed(driving_by_rc()))

    async def quit_it() -> None:
        async with app.run_test(size=SIZE) as pilot:
            await pilot.press("q")
            await pilot.pause()

    asyncio.run(quit_it())
    assert app.return_code == 0


def test_ctrl_c_quits_the_view() -> None:
    """Issue 32, defect 7: Textual's Ctrl-C only hinted at ctrl+q."""
    app = DashboardApp(Feed(driving_by_rc()))

    async def interrupt() -> bool:
        async with app.run_test(size=SIZE) as pilot:
            await pilot.press("ctrl+c")
            await pilot.pause()
            return app.is_running

    assert asyncio.run(interrupt()) is False
    assert app.return_code == 0


def test_the_scenario_s_verdict_is_shown_beside_the_flags_once_known() -> None:
    """Issue 32, defect 10: the view never said whether the scenario it started passed."""
    verdicts: list[str | None] = [None]
    app = DashboardApp(Feed(driving_by_rc()), source="scenario x", verdict=lambda: verdicts[-1])

    async def look() -> tuple[str, str]:
        async with app.run_test(size=SIZE) as pilot:
            await pilot.pause()
            before = _panel(app, "flags")
            verdicts.append("FAILED (5 of 7 passed)")
            app.refresh_view()
            return before, _panel(app, "flags")

    before, after = asyncio.run(look())
    assert before == "error flags: none"
    assert after == "error flags: none  ·  scenario FAILED (5 of 7 passed)"
