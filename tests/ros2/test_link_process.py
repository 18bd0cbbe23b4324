"""The CAN link in a process of its own (as `bywire ros2` runs it), without ROS: it refuses a
bus it cannot open in one line, drives the simulated robot served over socketcand, and stops
sending when its parent closes it."""

from __future__ import annotations

import functools
import re
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from bywire.cli.ros2 import open_link
from bywire.config.vehicle import VehicleSection
from bywire.errors import HardwareError
from bywire.model import ControlMode
from bywire.ros2.bridge import Activity
from bywire.ros2.enabling import Answer
from bywire.ros2.link_process import LinkOptions, LinkProcess, Opener
from bywire.ros2.setpoint import Setpoint
from bywire.ros2.settings import BridgeSettings, Geometry

OPTIONS = LinkOptions(BridgeSettings(), Geometry.of(VehicleSection()), None)


def _bus(port: int) -> dict[str, object]:
    return {
        "interface": "socketcand",
        "channel": "can0",
        "bus_kwargs": [],
        "host": "127.0.0.1",
        "port": port,
        "bitrate": None,
    }


def _opener(port: int) -> Opener:
    return functools.partial(open_link, _bus(port), None, Path("unused"))


@pytest.fixture
def served() -> Iterator[int]:
    """The simulated robot waiting in CAN mode, its bus served on a free loopback port."""
    command = [sys.executable, "-m", "bywire", "sim", "--scenario", "teleop", "--realtime"]
    command += ["--serve", "0", "--duration", "60"]
    process = subprocess.Popen(
        command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    try:
        assert process.stderr is not None
        found = re.search(r"port (\d+)", process.stderr.readline())
        assert found is not None
        yield int(found.group(1))
    finally:
        process.terminate()
        process.wait(timeout=15)


def test_a_bus_that_cannot_be_opened_is_one_line(unused_port: int) -> None:
    with pytest.raises(HardwareError, match=f"nothing answers on 127.0.0.1 port {unused_port}"):
        LinkProcess(_opener(unused_port), OPTIONS)


@pytest.fixture
def unused_port() -> int:
    import socket  # noqa: PLC0415

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port


def _wait(condition: Callable[[], bool], timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return False


def test_the_link_process_drives_the_served_robot_and_stops_when_closed(served: int) -> None:
    link = LinkProcess(_opener(served), OPTIONS)
    try:
        assert _wait(lambda: link.snapshot().status.mode is ControlMode.STOP, 5.0)
        answers: list[Answer] = []
        deadline = time.monotonic() + 10.0  # until the transmitter's switch has settled at CAN
        while time.monotonic() < deadline and not (answers and answers[-1].armed):
            answer = link.answer(link.request_enable(), 5.0)
            assert answer is not None
            answers.append(answer)
        assert answers[-1].armed, answers
        end = time.monotonic() + 3.0
        while time.monotonic() < end:
            link.offer(Setpoint(0.5, 0.0, link.now(), 0.0))
            time.sleep(0.05)
        snapshot = link.snapshot()
        assert snapshot.status.speed_mps > 0.3
        assert snapshot.decision is not None
        assert snapshot.decision.activity is Activity.DRIVING
    finally:
        link.close()
    assert not link.alive
