"""The run record's format: every value round-trips exactly; a file that is no record is refused."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from bywire.can_frame import CanFrame
from bywire.errors import ConfigError
from bywire.hal.ports import LinkState
from bywire.hal.tape.run_record import Output, RecordHeader, read_record, write_record

HEADER = RecordHeader("tiny", 0.0, 1.0, {"steering": 0.02, "hydrobrake": 0.001}, (), "")


@pytest.mark.parametrize("name", ["run.jsonl", "run.jsonl.gz"])
def test_the_record_round_trips_every_value_exactly(name: str, tmp_path: Path) -> None:
    events = [
        {"t": 0.1 + 0.2, "kind": "rc_bytes", "hex": "2040"},
        {"t": 0.35, "kind": "rc_bytes", "hex": "01", "at": 0.3499},
        {"t": 0.5, "kind": "can_rx", "frames": [[0x101, "00ff", 0.49]]},
        {"t": 0.5, "kind": "sensor", "name": "wheel_speeds", "read": 3, "value": (0.1, -0.3)},
        {"t": 0.6, "kind": "refused", "name": "dac", "call": 7},
        {"t": 0.7, "kind": "out", "name": "steering_pwm", "value": 0.0015000000000000002},
        {"t": 0.7, "kind": "out", "name": "gpio.low_beam", "value": True},
        {"t": 0.8, "kind": "link", "name": "can", "down": True, "reopen_failures": 2,
         "receive_failures": 1},
        {"t": 0.9, "kind": "link", "name": "rc_uart", "down": False, "reopen_failures": 0,
         "receive_failures": 3},
    ]  # fmt: skip
    assert write_record(tmp_path / name, HEADER, events) == len(events)
    run = read_record(tmp_path / name)
    assert run.header == HEADER
    assert run.rc_bytes == [(0.1 + 0.2, b"\x20\x40", None), (0.35, b"\x01", 0.3499)]
    assert run.can_rx == [(0.5, [CanFrame(0x101, b"\x00\xff", 0.49)])]
    assert run.sensor_reads == {"wheel_speeds": [(3, (0.1, -0.3))]}
    assert run.refusals == {"dac": {7}}
    assert run.links == {
        "can": [(0.8, LinkState(down=True, reopen_failures=2, receive_failures=1))],
        "rc_uart": [(0.9, LinkState(receive_failures=3))],
    }
    assert run.outputs == [
        Output(0.7, "steering_pwm", 0.0015000000000000002),
        Output(0.7, "gpio.low_beam", True),
    ]


def test_a_gzip_record_is_compressed(tmp_path: Path) -> None:
    write_record(tmp_path / "run.jsonl.gz", HEADER, [])
    with gzip.open(tmp_path / "run.jsonl.gz", "rt") as stream:
        assert json.loads(stream.readline())["format"] == "bywire-run-record"


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        (["{}"], "line 1: .*not a bywire-run-record"),
        (['{"format": "bywire-run-record", "version": 99}'], "line 1: .*version 99"),
        ([json.dumps(HEADER.as_json()), '{"t": 1, "kind": "teleport"}'], "line 2: .*teleport"),
        ([json.dumps(HEADER.as_json()), "", "not json"], "line 3"),
        (
            [
                json.dumps(HEADER.as_json()),
                '{"t": 1, "kind": "link", "name": "dac", "down": true,'
                ' "reopen_failures": 0, "receive_failures": 0}',
            ],
            "line 2: .*link name 'dac'",
        ),
        (
            [
                json.dumps(HEADER.as_json()),
                '{"t": 1, "kind": "link", "name": "can", "down": 1,'
                ' "reopen_failures": 0, "receive_failures": 0}',
            ],
            "line 2: .*link down 1",
        ),
        ([], "line 1"),
    ],
)
def test_a_file_that_is_no_record_is_refused_naming_the_line(
    lines: list[str], message: str, tmp_path: Path
) -> None:
    path = tmp_path / "bad.jsonl"
    path.write_text("\n".join(lines), encoding="utf-8")
    with pytest.raises(ConfigError, match=message):
        read_record(path)


def test_a_missing_record_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such run record"):
        read_record(tmp_path / "missing.jsonl")
