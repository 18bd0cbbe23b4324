"""`bywire sim --mcap` and `--foxglove`: the telemetry feed of a run, read back by the field's
own tools (the `mcap` reader, a Foxglove WebSocket client) and checked against the simulated
hardware's recorded levels."""

from __future__ import annotations

import bisect
import contextlib
import io
import json
import math
import re
import struct
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

import pytest
from mcap.reader import make_reader
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

from bywire.cli import sim as sim_command
from bywire.cli.main import main
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.hal.simulated.world import SimWorld
from bywire.protocol import dbc
from bywire.sim.runner import SimRun
from bywire.telemetry.schemas import CAN_TOPIC, EVENTS_TOPIC, SCHEMAS, STATE_TOPIC, VEHICLE_TOPIC

TOPICS = {STATE_TOPIC, EVENTS_TOPIC, CAN_TOPIC}
LIMIT_S = 30.0  # generous limits on waiting, never timing assertions
# The SDK's server speaks protocol v1 under this name; the Foxglove app offers it along with
# the older "foxglove.websocket.v1" and the server refuses a client that offers neither.
SUBPROTOCOLS = [Subprotocol("foxglove.sdk.v1"), Subprotocol("foxglove.websocket.v1")]
MESSAGE_DATA = 0x01  # the protocol's binary opcode: u8 op, u32 subscription, u64 time, payload


def run_sim(*argv: str) -> tuple[int, str]:
    """`bywire sim ARGV` in this process: (exit status, stderr)."""
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        try:
            status = main(["sim", *argv])
        except SystemExit as exit:  # argparse refuses a malformed value
            status = int(exit.code or 0)
    return status, err.getvalue()


class RecordedRun(SimRun):
    """A SimRun that a test can find after the command built it, with every frame that crossed
    its bus."""

    built: ClassVar[list[RecordedRun]] = []

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.frames: list[LoggedFrame] = []
        self.add_can_monitor(self.frames.append)
        RecordedRun.built.append(self)


@pytest.fixture
def runs(monkeypatch: pytest.MonkeyPatch) -> list[RecordedRun]:
    """Every SimRun the command builds, so a test can read its simulated hardware."""
    RecordedRun.built = []
    monkeypatch.setattr(sim_command, "SimRun", RecordedRun)
    return RecordedRun.built


def read_mcap(path: Path, topics: set[str] = TOPICS) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """(topic, log time in ns, decoded message) for every message of the JSON `topics` (the
    feed's own, by default), in log-time order."""
    with path.open("rb") as stream:
        for _schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
            if channel.topic in topics:
                yield channel.topic, message.log_time, json.loads(message.data)


def wall_offset_ns(messages: list[tuple[str, int, dict[str, Any]]]) -> int:
    """The one offset from the run's clock to the log times (the run's wall-clock start)."""
    offsets = {log_time_ns - round(body["time_s"] * 1e9) for _, log_time_ns, body in messages}
    assert max(offsets) - min(offsets) <= 1, "not one offset"
    return int(min(offsets))


def level_at(history: list[tuple[float, Any]], time_s: float) -> Any:
    """The level a simulated output held at `time_s` (the latest change at or before it)."""
    index = bisect.bisect_right(history, time_s, key=lambda entry: entry[0])
    assert index > 0, f"nothing written by {time_s}"
    return history[index - 1][1]


def hardware_at(world: SimWorld, time_s: float) -> dict[str, Any]:
    """What the simulated robot's ports held at `time_s`: the truth a message must match."""
    dac = [(t, volts) for t, channel, volts in world.dac.history if channel == 0]
    return {
        "dac_throttle_volts": level_at(dac, time_s),
        "motors_enabled": level_at(world.gpio["motors_enable"].history, time_s),
        "ebrake_engaged": not level_at(world.gpio["ebrake_release"].history, time_s),
        "steering_pulse_ms": level_at(world.pwm.steering.history, time_s) * 1000.0,
    }


def hardware_during(world: SimWorld, start_s: float, end_s: float) -> dict[str, set[Any]]:
    """Every level each port held from `start_s` to `end_s`. On real time the clock moves on
    during a pass, so its writes are stamped a little after the `now` the pass was taken at."""
    dac = [(t, volts) for t, channel, volts in world.dac.history if channel == 0]
    histories: dict[str, list[tuple[float, Any]]] = {
        "dac_throttle_volts": dac,
        "motors_enabled": world.gpio["motors_enable"].history,
        "ebrake_engaged": [(t, not level) for t, level in world.gpio["ebrake_release"].history],
        "steering_pulse_ms": [(t, pulse_s * 1000.0) for t, pulse_s in world.pwm.steering.history],
    }
    return {
        name: {level_at(history, start_s)} | {v for t, v in history if start_s < t <= end_s}
        for name, history in histories.items()
    }


def outputs_of(state: dict[str, Any]) -> dict[str, Any]:
    """The levels of a state message that `hardware_at` reads back from the ports."""
    return {key: state["outputs"][key] for key in HARDWARE_FIELDS}


HARDWARE_FIELDS = ("dac_throttle_volts", "motors_enabled", "ebrake_engaged", "steering_pulse_ms")


# --- MCAP ---------------------------------------------------------------------------------------


def test_an_mcap_holds_every_channel_for_the_whole_run_in_simulated_time(
    tmp_path: Path, runs: list[RecordedRun]
) -> None:
    path = tmp_path / "course.mcap"
    before_ns = time.time_ns()
    status, _ = run_sim("--duration", "24", "--mcap", str(path))
    assert status == 0
    messages = list(read_mcap(path))
    offset_ns = wall_offset_ns(messages)  # the run's wall-clock start, simulated offsets kept
    assert before_ns <= offset_ns <= time.time_ns()
    times_s: dict[str, list[float]] = {topic: [] for topic in TOPICS}
    for topic, log_time_ns, _body in messages:
        times_s[topic].append((log_time_ns - offset_ns) / 1e9)
    states = times_s[STATE_TOPIC]
    assert states == pytest.approx([k / 50 for k in range(24 * 50)], abs=1e-9)
    # Every frame that crossed the bus, in order, start to end.
    crossed = [(f.time_s, f.arbitration_id, f.data.hex()) for f in runs[0].frames]
    can = [
        (body["time_s"], body["arbitration_id"], body["data_hex"])
        for topic, _, body in messages
        if topic == CAN_TOPIC
    ]
    assert can == crossed
    assert can[0][0] < 0.02
    assert can[-1][0] > 23.98
    events = [body for topic, _, body in messages if topic == EVENTS_TOPIC]
    assert [event["name"] for event in events if event["kind"] == "mode"] == ["STOP", "RC", "CAN"]


def test_an_mcap_speaks_foxglove_s_own_terms(tmp_path: Path, runs: list[RecordedRun]) -> None:
    """Issue 32, what Foxglove users expect: wall-clock log times, CAN frames decoded with the
    DBC on topics of their own, events on foxglove.Log, error flags by name, and the simulated
    vehicle's pose (foxglove.PoseInFrame and a FrameTransform) for the 3D panel."""
    path = tmp_path / "course.mcap"
    before_ns = time.time_ns()
    assert run_sim("--duration", "12", "--mcap", str(path))[0] == 0
    after_ns = time.time_ns()
    with path.open("rb") as stream:
        read = list(make_reader(stream).iter_messages(log_time_order=True))
    by_topic: dict[str, list[Any]] = {}
    for schema, channel, message in read:
        by_topic.setdefault(channel.topic, []).append((schema, message))
    first_ns, last_ns = read[0][2].log_time, read[-1][2].log_time
    assert before_ns <= first_ns <= after_ns  # the run's wall-clock start, not 1970
    assert 11.9e9 < last_ns - first_ns <= 12e9  # the simulated seconds kept
    movements = [json.loads(m.data) for _, m in by_topic["/bywire/can/MovementCommand"]]
    sent = [
        dbc.database().decode_message(0x101, frame.data, decode_choices=False)
        for frame in runs[0].frames
        if frame.arbitration_id == 0x101
    ]
    signals = [{k: v for k, v in m.items() if k not in ("time_s", "sender")} for m in movements]
    assert signals == sent
    assert max(m["throttle_norm"] for m in movements) > 0.1  # the course drives by CAN
    (log_schema,) = {schema.name for schema, _ in by_topic["/bywire/log"]}
    assert log_schema == "foxglove.Log"
    assert len(by_topic["/bywire/log"]) == len(by_topic[EVENTS_TOPIC])
    flags = [json.loads(m.data) for _, m in by_topic["/bywire/flags"]]
    assert len(flags) == len(by_topic[STATE_TOPIC])
    assert any(f["NOT_ARMED"] for f in flags)
    assert not flags[-1]["NOT_ARMED"]
    pose_schemas = {schema.name for schema, _ in by_topic["/bywire/pose"] + by_topic["/bywire/tf"]}
    assert pose_schemas == {"foxglove.PoseInFrame", "foxglove.FrameTransform"}
    path_m = [json.loads(m.data) for _, m in by_topic[VEHICLE_TOPIC]]
    assert math.hypot(path_m[-1]["x_m"], path_m[-1]["y_m"]) > 1.0  # it went somewhere


def test_mcap_channels_carry_their_json_schemas(tmp_path: Path) -> None:
    path = tmp_path / "short.mcap"
    assert run_sim("--duration", "1", "--mcap", str(path))[0] == 0
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    channels = {channel.topic: channel for channel in summary.channels.values()}
    assert set(SCHEMAS) <= set(channels)
    for topic in SCHEMAS:
        channel = channels[topic]
        schema = summary.schemas[channel.schema_id]
        assert (channel.message_encoding, schema.encoding) == ("json", "jsonschema")
        assert json.loads(schema.data) == SCHEMAS[topic]


def test_every_state_message_matches_the_simulated_hardware_at_its_time(
    tmp_path: Path, runs: list[RecordedRun]
) -> None:
    """The course drives under RC from 1.5 s: the DAC, the enable line, the e-brake and the
    servo, each read back from the simulated ports, at every one of 500 messages."""
    path = tmp_path / "course.mcap"
    assert run_sim("--duration", "10", "--mcap", str(path))[0] == 0
    world = runs[0].world
    messages = list(read_mcap(path))
    offset_ns = wall_offset_ns(messages)
    states = [((t - offset_ns) / 1e9, body) for topic, t, body in messages if topic == STATE_TOPIC]
    assert len(states) == 500
    driving = [body for _, body in states if body["outputs"]["dac_throttle_volts"] > 0]
    assert len(driving) > 100
    for time_s, body in states:
        assert body["time_s"] == pytest.approx(time_s, abs=1e-9)
        assert outputs_of(body) == hardware_at(world, time_s), time_s
    # The last message is the last pass's: the ports still held its levels when the run ended
    # (before the exit's safe writes, which the history shows after it).
    assert states[-1][1]["outputs"]["dac_throttle_volts"] == level_at(
        [(t, v) for t, channel, v in world.dac.history if channel == 0], 9.98
    )


def test_a_realtime_mcap_is_stamped_with_wall_clock_time(tmp_path: Path) -> None:
    path = tmp_path / "live.mcap"
    before_ns = time.time_ns()
    assert run_sim("--realtime", "--duration", "1", "--mcap", str(path))[0] == 0
    after_ns = time.time_ns()
    messages = list(read_mcap(path))
    assert {topic for topic, _, _ in messages} == TOPICS
    assert all(before_ns <= log_time_ns <= after_ns for _, log_time_ns, _ in messages)
    wall_offset_ns(messages)  # one offset maps the controller's clock to the wall clock
    states = [body for topic, _, body in messages if topic == STATE_TOPIC]
    assert states[-1]["time_s"] > 0.5  # the run's whole second, not only its start


# --- Foxglove live ------------------------------------------------------------------------------


def _wait_for_url(capsys: pytest.CaptureFixture[str]) -> str:
    """The ws:// address the command prints to stderr once it serves."""
    seen = ""
    deadline = time.monotonic() + LIMIT_S
    while time.monotonic() < deadline:
        seen += capsys.readouterr().err
        found = re.search(r"ws://\S+:\d+", seen)
        if found:
            return found.group()
        time.sleep(0.05)
    raise AssertionError(f"no Foxglove address on stderr: {seen!r}")


def _advertised(client: ClientConnection) -> dict[str, dict[str, Any]]:
    """Read the server's JSON messages up to its channel advertisement: {topic: channel}."""
    while True:
        text = client.recv(timeout=LIMIT_S)
        assert isinstance(text, str)
        body = json.loads(text)
        if body["op"] == "advertise":
            return {channel["topic"]: channel for channel in body["channels"]}


def _messages(client: ClientConnection) -> Iterator[tuple[int, dict[str, Any]]]:
    """(subscription id, decoded JSON payload) of each message the server sends."""
    while True:
        data = client.recv(timeout=LIMIT_S)
        if isinstance(data, bytes) and data[0] == MESSAGE_DATA:
            _op, subscription, _log_time_ns = struct.unpack_from("<BIQ", data)
            yield subscription, json.loads(data[13:])


def test_a_foxglove_client_sees_the_channels_and_live_values_of_the_simulated_hardware(
    capsys: pytest.CaptureFixture[str], runs: list[RecordedRun]
) -> None:
    argv = ["sim", "--realtime", "--duration", "60", "--foxglove", "127.0.0.1:0"]
    command = threading.Thread(target=main, args=(argv,), daemon=True)
    command.start()
    try:
        url = _wait_for_url(capsys)
        with connect(url, subprotocols=SUBPROTOCOLS, open_timeout=LIMIT_S) as client:
            channels = _advertised(client)
            assert set(SCHEMAS) <= set(channels)  # and Foxglove's own topics beside them
            for topic in SCHEMAS:
                channel = channels[topic]
                assert (channel["encoding"], channel["schemaEncoding"]) == ("json", "jsonschema")
                assert json.loads(channel["schema"]) == SCHEMAS[topic]
            subscribe = [{"id": 7, "channelId": channels[STATE_TOPIC]["id"]}]
            client.send(json.dumps({"op": "subscribe", "subscriptions": subscribe}))
            # Under RC the course drives from 1.5 s: wait for a state with throttle on the DAC,
            # and the next one, which ends the window its pass wrote in.
            states: list[dict[str, Any]] = []
            for subscription, state in _messages(client):
                assert subscription == 7
                if states or state["outputs"]["dac_throttle_volts"] > 0:
                    states.append(state)
                if len(states) == 2:
                    break
        driving, after = states
        held = hardware_during(runs[0].world, driving["time_s"], after["time_s"])
        for name, value in outputs_of(driving).items():
            assert value in held[name], (name, value, held[name])
    finally:
        if runs:
            runs[0].runtime.request_stop()
        command.join(LIMIT_S)
    assert not command.is_alive()


@pytest.mark.parametrize(
    ("argv", "complaint"),
    [
        (["--foxglove", "0.0.0.0:8765", "--realtime"], "loopback only"),
        (["--foxglove", "192.168.1.5:8765", "--realtime"], "loopback only"),
        (["--foxglove", "8765"], "--foxglove needs --realtime"),
        (["--mcap", "run.txt"], "ends in .mcap"),
        (["--mcap", "no-such-folder/run.mcap"], "does not exist"),
        (["--telemetry-rate", "0", "--mcap", "x.mcap"], "rate in Hz > 0"),
        (["--all", "--mcap", "x.mcap"], "--mcap: for one scenario"),
    ],
)
def test_bad_telemetry_options_are_one_line_and_exit_2(
    argv: list[str], complaint: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    status, err = run_sim(*argv)
    assert status == 2
    assert complaint in err.strip().splitlines()[-1]
    assert not list(tmp_path.iterdir())  # refused before anything was written
