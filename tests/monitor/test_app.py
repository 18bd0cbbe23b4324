"""The live monitor, headless (textual's pilot), on a simulated robot running in real time."""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable, Iterator

import pytest
from textual.widgets import DataTable

from bywire.config import default_sim_config
from bywire.hal.simulated.can_bus import SimCanBus
from bywire.hal.simulated.clock import VirtualClock
from bywire.loopback import Endpoint
from bywire.monitor.app import MonitorApp
from bywire.monitor.bus_reader import CanFeed, open_bus
from bywire.monitor.bus_state import BusModel
from bywire.netbus.bridge import serve_bus
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun

RUN_S = 4.0
TIMEOUT_S = 10.0


@pytest.fixture
def served_sim() -> Iterator[tuple[str, int]]:
    """The test course in real time on a thread, its bus served on a free loopback port."""
    sim = SimRun(
        default_sim_config(), find_scenario("test-course"), realtime=True, duration_s=RUN_S
    )
    with serve_bus(sim.world.bus, Endpoint("127.0.0.1", 0), sim.started_at) as bridge:
        thread = threading.Thread(target=sim.run, daemon=True)
        thread.start()
        yield bridge.server.address
        thread.join(timeout=RUN_S + TIMEOUT_S)


def _row_texts(table: DataTable[object]) -> dict[str, list[str]]:
    rows = {}
    for row_key in table.rows:
        cells = table.get_row(row_key)
        rows[str(cells[1])] = [str(cell) for cell in cells]
    return rows


def test_the_monitor_shows_the_decoded_frames_of_a_running_simulation(
    served_sim: tuple[str, int],
) -> None:
    host, port = served_sim
    feed = CanFeed(open_bus("socketcand", "can0", host, port))
    app = MonitorApp(feed, BusModel(), f"socketcand @ {host}:{port}")

    async def watch() -> dict[str, list[str]]:
        async with app.run_test(size=(200, 30)) as pilot:
            table = app.query_one(DataTable)
            deadline = time.monotonic() + TIMEOUT_S
            while "gear=" not in " ".join(_row_texts(table).get("ModeReport", [])):
                assert time.monotonic() < deadline, "ModeReport never shown decoded"
                await pilot.pause(0.1)
            await pilot.press("q")
            return _row_texts(table)

    feed.start()
    try:
        rows = asyncio.run(watch())
    finally:
        feed.stop()
    assert {"ModeReport", "MovementCommand", "StatusReport", "ErrorReport"} <= set(rows)
    movement = rows["MovementCommand"]
    assert movement[0] == "0x101"
    assert "steering_norm=" in movement[7]
    assert movement[6] == "-"  # the simulated computer's commands pass the CRC and counter checks
    assert "control_mode=" in rows["ModeReport"][7]


def _wait_for(condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + TIMEOUT_S
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def test_the_feed_notices_a_dead_server_and_reconnects_when_it_is_back() -> None:
    bus = SimCanBus(VirtualClock())
    endpoint = Endpoint("127.0.0.1", 0)
    with serve_bus(bus, endpoint, 0.0) as bridge:
        host, port = bridge.server.address
        feed = CanFeed(
            open_bus("socketcand", "can0", host, port),
            reopen=lambda: open_bus("socketcand", "can0", host, port),
        )
        feed.start()
        assert feed.connection == "connected"
    try:
        _wait_for(lambda: feed.connection.startswith("lost ("), "the lost server never noticed")
        assert "every 1 s" in feed.connection  # reconnecting, or retrying while nothing answers
        with serve_bus(bus, Endpoint("127.0.0.1", port), 0.0):
            _wait_for(lambda: feed.reconnects == 1, "never reconnected")
            assert feed.connection == "connected (reconnected 1×)"
    finally:
        feed.stop()
