"""`bywire sim --rosbag DIR`: a rosbag2 MCAP of the run, read back with two independent readers
(rosbags' and mcap-ros2-support's) and checked against the CAN log of the same run."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import can
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from bywire.cli.main import main
from bywire.model import REPORT_TYPES, WheelSpeedReport
from bywire.protocol import dbc
from bywire.ros2.bag import CAN_TOPIC, report_topic

DURATION_S = 12.0


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("bag")
    bag, log = folder / "run-bag", folder / "run.asc"
    status = main(
        ["sim", "--duration", str(DURATION_S), "--rosbag", str(bag), "--log", str(log), "--json"]
    )
    assert status in {0, 1}  # cut short: expectations not reached are failures, not errors
    return bag, log


def _log_frames(log: Path) -> list[can.Message]:
    return list(can.ASCReader(log))


def _read(bag: Path, topic: str) -> list[Any]:
    """Every message on `topic`, deserialised by rosbags."""
    with AnyReader([bag]) as reader:
        connections = [c for c in reader.connections if c.topic == topic]
        return [reader.deserialize(raw, c.msgtype) for c, _t, raw in reader.messages(connections)]


def test_rosbags_reads_every_frame_of_the_can_log(run: tuple[Path, Path]) -> None:
    bag, log = run
    frames = _log_frames(log)
    read = _read(bag, CAN_TOPIC)
    assert len(read) == len(frames) > 1000
    for message, frame in zip(read, frames, strict=True):
        assert message.id == frame.arbitration_id
        assert bytes(message.data[: message.dlc]) == bytes(frame.data)


def test_rosbags_reads_reports_odometry_and_diagnostics(run: tuple[Path, Path]) -> None:
    bag, _log = run
    with AnyReader([bag]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    odom, arrays = _read(bag, "/odom"), _read(bag, "/diagnostics")
    reports_per_topic = round(DURATION_S / 0.02)
    for kind in REPORT_TYPES:
        assert abs(counts[report_topic(kind)] - reports_per_topic) <= 2
    assert counts["/odom"] == counts[report_topic(WheelSpeedReport)]
    assert max(m.twist.twist.linear.x for m in odom) > 0.5  # the test course drives by RC
    assert odom[-1].pose.pose.position.x > 1.0
    assert len(arrays) == pytest.approx(DURATION_S, abs=1.5)
    names = {status.name for status in arrays[-1].status}
    assert {"bywire: mode", "bywire: CAN link", "bywire: RC link"} <= names


def _decoded(mcap_file: Path, topic: str) -> list[tuple[int, Any]]:
    """(log time, message) of every message on `topic`, decoded by mcap-ros2-support."""
    with mcap_file.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [
            (message.log_time, decoded)
            for _schema, _channel, message, decoded in reader.iter_decoded_messages(topics=[topic])
        ]


def test_mcap_ros2_support_decodes_the_same_bag(run: tuple[Path, Path]) -> None:
    bag, _log = run
    (mcap_file,) = bag.glob("*.mcap")
    modes = [m for _t, m in _decoded(mcap_file, "/bywire/report/mode")]
    assert {m.control_mode for m in modes} >= {"STOP", "RC"}
    assert modes[0].estop_engaged is True
    errors = [m for _t, m in _decoded(mcap_file, "/bywire/report/error")]
    assert "NOT_ARMED" in errors[0].flag_names
    frames = _decoded(mcap_file, CAN_TOPIC)
    assert {m.id for _t, m in frames} >= set(dbc.report_ids())
    times = [t for t, _m in frames]
    assert times == sorted(times)


def test_an_existing_folder_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--duration", "1", "--rosbag", str(tmp_path)]) == 2
    assert "it exists" in capsys.readouterr().err


def test_without_rosbags_the_flag_says_how_to_get_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "rosbags.rosbag2", None)
    monkeypatch.delitem(sys.modules, "bywire.ros2.bag", raising=False)
    assert main(["sim", "--duration", "1", "--rosbag", str(tmp_path / "bag")]) == 2
    assert "pip install 'bywire[ros]'" in capsys.readouterr().err
    assert not (tmp_path / "bag").exists()


def test_a_can_log_exports_to_the_same_bag(
    run: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag, log = run
    exported = tmp_path / "from-log"
    assert main(["ros2", "--export", str(log), str(exported)]) == 0
    assert f"rosbag2: {exported} ({len(_log_frames(log))} frames" in capsys.readouterr().out
    for topic in (CAN_TOPIC, "/bywire/report/mode", "/odom"):
        assert len(_read(exported, topic)) == len(_read(bag, topic))
    from_log = _read(exported, "/bywire/report/wheel_speed")
    from_run = _read(bag, "/bywire/report/wheel_speed")
    assert [m.left_mps for m in from_log] == [m.left_mps for m in from_run]
