"""`bywire run` with its telemetry feed, on the robot stand-ins (tests/hal/linux): an MCAP that
holds the state, the events and the CAN frames both ways, read back with the `mcap` reader; a
Foxglove client attached to the server a `[telemetry]` section asks for; bad options refused
before any device is opened."""

from __future__ import annotations

import json
import re
import signal
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from bywire.dashboard.client import FeedClient
from bywire.model import ControlMode
from bywire.protocol import dbc
from bywire.telemetry.schemas import CAN_TOPIC, EVENTS_TOPIC, SCHEMAS, STATE_TOPIC
from tests.cli.test_run import (
    LIMIT_S,
    Robot,
    _assert_de_energised,
    _on_a_host_that_keeps_time,
    _stop_armed,
)
from tests.hal.linux.bench import Bench, make_bench
from tests.hal.linux.pty_rc import PtyRcLine

MCAP_MAGIC = b"\x89MCAP0\r\n"  # an MCAP file begins and, once finished, ends with it
FINISH_WAIT_S = 30.0  # generous: only a writer that never finishes reaches it


def read_mcap(path: Path) -> list[tuple[str, dict[str, Any]]]:
    """The messages of a finished file. The writer's process finishes it after the controller
    has exited (it sees the pipe close), so this waits for the closing magic first."""
    deadline = time.monotonic() + FINISH_WAIT_S
    while not path.read_bytes().endswith(MCAP_MAGIC):
        assert time.monotonic() < deadline, f"{path} was never finished"
        time.sleep(0.02)
    with path.open("rb") as stream:
        return [
            (channel.topic, json.loads(message.data))
            for _s, channel, message in make_reader(stream).iter_messages(log_time_order=True)
            if channel.topic in SCHEMAS  # the feed's own JSON topics
        ]


def test_run_records_state_events_and_the_can_frames_both_ways_to_mcap(tmp_path: Path) -> None:
    _on_a_host_that_keeps_time(tmp_path, _record)


def _record(bench: Bench, line: PtyRcLine) -> None:
    path = bench.root / "robot.mcap"
    robot = Robot(bench, line, extra=("--mcap", str(path)))
    try:
        robot.command(steering=0.0, throttle=0.0, brake=0.5, gear="forward")
        robot.wait_for("armed in STOP", lambda: robot.reports() == _stop_armed(robot))
        line.transmitter.set_mode(ControlMode.RC)
        robot.wait_for("RC mode in the reports", lambda: robot.reports()["mode"] == "RC")
        # The writer, with foxglove's 39 MB native core, is a process of its own, and without a
        # key nothing loads cryptography's 11 MB: with lock_memory every mapped page is resident.
        mapped = Path(f"/proc/{robot.process.pid}/maps").read_text(encoding="ascii")
        robot.process.send_signal(signal.SIGTERM)
        assert robot.finish() == 0, robot.errors()
    finally:
        robot.kill()
    assert "[stack]" in mapped  # a live process's map was read
    assert "_foxglove_py" not in mapped
    assert "cryptography" not in mapped
    _assert_de_energised(bench)
    messages = read_mcap(path)
    states = [body for topic, body in messages if topic == STATE_TOPIC]
    assert {"STOP", "RC"} <= {state["mode"] for state in states}
    events = [body for topic, body in messages if topic == EVENTS_TOPIC]
    assert [e["name"] for e in events if e["kind"] == "mode"][:2] == ["STOP", "RC"]
    frames = [body for topic, body in messages if topic == CAN_TOPIC]
    sent = {frame["arbitration_id"] for frame in frames if frame["sender"] == "bywire"}
    received = {frame["arbitration_id"] for frame in frames if frame["sender"] == ""}
    assert sent == set(dbc.report_ids())
    assert received == {0x101}  # the higher-level computer's MovementCommand
    # The last state was taken in RC mode, before the stop's safe writes.
    assert states[-1]["mode"] == "RC"
    assert "Traceback" not in robot.errors()


class StderrLines:
    """Every line the process writes to stderr, read as it comes (the server's port is there)."""

    def __init__(self, robot: Robot) -> None:
        self.lines: list[str] = []
        assert robot.process.stderr is not None
        self._stream = robot.process.stderr
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for text in self._stream:
            self.lines.append(text)

    def find(self, robot: Robot, pattern: str) -> str:
        """The first group of `pattern` in the first line that has it (waits for the line)."""
        expression = re.compile(pattern)

        def match() -> re.Match[str] | None:
            return next(filter(None, map(expression.search, list(self.lines))), None)

        robot.wait_for(pattern, lambda: match() is not None)
        found = match()
        assert found is not None
        return found[1]


def test_a_foxglove_client_attaches_to_the_server_the_telemetry_section_asks_for(
    tmp_path: Path,
) -> None:
    _on_a_host_that_keeps_time(tmp_path, _attach)


def _attach(bench: Bench, line: PtyRcLine) -> None:
    telemetry = ('[telemetry]\nfoxglove = "127.0.0.1:0"\nrate_hz = 20',)
    robot = Robot(bench, line, config_lines=telemetry)
    errors = StderrLines(robot)
    try:
        url = errors.find(robot, r"serving telemetry to Foxglove on (ws://127\.0\.0\.1:\d+)")
        robot.command(steering=0.0, throttle=0.0, brake=0.5, gear="forward")
        robot.wait_for("armed in STOP", lambda: robot.reports() == _stop_armed(robot))
        client = FeedClient(url).start()
        try:
            robot.wait_for("an armed state on the feed", lambda: _armed(client.latest()))
            state = client.latest()
            assert state is not None
            assert state["outputs"]["ebrake_engaged"] is True
            assert state["outputs"]["motors_enabled"] is False
            assert [task["name"] for task in state["tasks"]][:3] == [  # in order of importance
                "hydrobrake",
                "steering",
                "driving",
            ]
        finally:
            client.close()
        robot.process.send_signal(signal.SIGTERM)
        assert robot.process.wait(LIMIT_S) == 0
    finally:
        robot.kill()
    _assert_de_energised(bench)


def _armed(state: dict[str, Any] | None) -> bool:
    return state is not None and state["mode"] == "STOP" and state["armed"]


@pytest.mark.parametrize(
    ("extra", "telemetry", "complaint"),
    [
        (("--mcap", "{tmp}/no-such-folder/run.mcap"), "", "does not exist"),
        (("--mcap", "{tmp}/run.txt"), "", "ends in .mcap"),
        ((), '[telemetry]\nfoxglove = "0.0.0.0:8765"', "allow_remote = true"),
    ],
    ids=["mcap-folder", "mcap-name", "remote-address"],
)
def test_bad_telemetry_settings_are_one_line_exit_2_and_nothing_opened(
    tmp_path: Path,
    line: PtyRcLine,
    extra: tuple[str, ...],
    telemetry: str,
    complaint: str,
) -> None:
    bench = make_bench(tmp_path)
    robot = Robot(
        bench,
        line,
        extra=tuple(arg.format(tmp=tmp_path) for arg in extra),
        config_lines=(telemetry,),
    )
    status = robot.finish()
    errors = robot.errors().strip().splitlines()
    assert status == 2
    assert len(errors) == 1, errors
    assert complaint in errors[0]
    assert not Path(f"{bench.gpio_chip}.state.json").exists()  # no line was ever requested
