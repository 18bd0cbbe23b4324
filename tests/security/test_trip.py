"""The controller's freshness file, attack by attack: deleted, truncated, corrupted, another key's
(or another kind of file), and every number at and past its edge. Each refuses the start in one
line that names the recovery command, leaves the file as it was, and leaves no temporary file;
a good file moves the trip counter on, on the disk, before the start goes on.

(Replay, pre-play and a rolled-back file, which need both ends: tests/security/test_restarts.py.)
"""

from __future__ import annotations

import datetime
import json
import os
import random
from pathlib import Path
from typing import Any

import pytest

from bywire.atomic_file import temporaries
from bywire.errors import ConfigError
from bywire.protocol import dbc
from bywire.protocol.secoc import MAX_COUNTER, MAX_TRIP, SecocKey
from bywire.security import freshness, trip
from bywire.security.freshness import FreshnessStore
from bywire.security.session import SecocReceiver, SecocSigner
from bywire.security.state_file import state_bytes
from bywire.security.trip import (
    MAX_LOADED_TRIP,
    TRIP_STEP,
    FreshnessError,
    read_trip,
    reset_trip,
    start_trip,
)
from tests.tmpfs import entries, fill, read_only, small_tmpfs

KEY = SecocKey(bytes(range(16)))
OTHER_KEY = SecocKey(bytes(16))
NOW = datetime.datetime(2026, 11, 26, 12, 0, tzinfo=datetime.UTC)
RECOVERY = "bywire keys reset-freshness --config ROBOT.toml"


@pytest.fixture
def good(tmp_path: Path) -> Path:
    path = tmp_path / "freshness.json"
    reset_trip(path, KEY, 41, NOW)
    return path


def _refused(path: Path, says: str) -> str:
    before = path.read_bytes() if path.is_file() else None
    with pytest.raises(FreshnessError) as refusal:
        start_trip(path, KEY, random.Random(1))
    message = str(refusal.value)
    assert "\n" not in message
    assert says in message
    assert RECOVERY in message or "bywire keys new" in message
    assert (path.read_bytes() if path.is_file() else None) == before  # the evidence kept
    assert temporaries(path) == []
    return message


def test_a_good_file_moves_the_trip_on_by_a_step_before_the_start_goes_on(good: Path) -> None:
    trips = [start_trip(good, KEY, random.Random(seed)) for seed in range(5)]
    assert all(
        0 < later - earlier <= TRIP_STEP
        for earlier, later in zip([41, *trips], trips, strict=False)
    )
    assert read_trip(good, KEY) == trips[-1]
    assert oct(good.stat().st_mode & 0o777) == "0o600"


def test_a_deleted_file_refuses_the_start(good: Path) -> None:
    good.unlink()
    message = _refused(good, "no freshness file: refusing to start")
    assert "makes one" in message


@pytest.mark.parametrize("keep", [0, 1, 20, -2])
def test_a_truncated_file_refuses_the_start(good: Path, keep: int) -> None:
    good.write_bytes(good.read_bytes()[:keep])
    _refused(good, "refusing to start")


@pytest.mark.parametrize(
    ("field", "value", "says"),
    [
        ("trip", 42, "fails its check (damaged or edited)"),  # a digit changed: a rollback by hand
        ("check", "0" * 16, "fails its check"),
        ("key_check", "ABCDEF", "of another key"),  # the key check value corrupted
        ("kind", "bywire sender freshness 1", "not a freshness file"),
    ],
)
def test_a_corrupted_file_refuses_the_start(good: Path, field: str, value: Any, says: str) -> None:
    document = json.loads(good.read_text())
    document[field] = value
    good.write_text(json.dumps(document))
    _refused(good, says)


def test_a_bit_flipped_anywhere_refuses_the_start(good: Path) -> None:
    data = good.read_bytes()
    for index in range(len(data)):
        flipped = bytearray(data)
        flipped[index] ^= 0x04
        good.write_bytes(bytes(flipped))
        with pytest.raises(FreshnessError):
            read_trip(good, KEY)


def test_a_foreign_file_refuses_the_start(tmp_path: Path, good: Path) -> None:
    other = tmp_path / "other.json"
    reset_trip(other, OTHER_KEY, 0, NOW)
    message = _refused(other, f"of another key (check value '{OTHER_KEY.check_value}'")
    assert f"the key's is {KEY.check_value}" in message
    sender = tmp_path / "sender.json"
    FreshnessStore(KEY, sender).adopt(5)  # a sender's file of the same key is not the trip's
    _refused(sender, "not a freshness file")


def _checked(path: Path, fields: dict[str, Any], kind: str = trip.KIND) -> Path:
    """A file whose check is right (made with the key), holding `fields`."""
    path.write_bytes(state_bytes(KEY, kind, fields))
    return path


def test_the_trip_at_its_edge_loads_and_the_next_start_stays_in_32_bits(tmp_path: Path) -> None:
    path = _checked(tmp_path / "f.json", {"trip": MAX_LOADED_TRIP})
    assert start_trip(path, KEY, random.Random(0)) <= MAX_TRIP
    path = _checked(tmp_path / "f.json", {"trip": MAX_LOADED_TRIP})
    assert start_trip(path, KEY, _Largest()) == MAX_TRIP
    _checked(path, {"trip": MAX_LOADED_TRIP + 1})
    _refused(path, "too near its end")


class _Largest(random.Random):
    def randint(self, a: int, b: int) -> int:
        return b


@pytest.mark.parametrize(
    "fields",
    [
        {"trip": -1},
        {"trip": MAX_TRIP + 1},
        {"trip": 2**64},
        {"trip": 10**30},
        {"trip": True},
        {"trip": 7.0},
        {"trip": "7"},
        {"trip": None},
        {"trip": [7]},
        {},
        {"trip": 7, "more": 1},
    ],
    ids=repr,
)
def test_every_out_of_range_or_mistyped_trip_refuses_the_start(
    tmp_path: Path, fields: dict[str, Any]
) -> None:
    path = _checked(tmp_path / "f.json", fields)
    _refused(path, "refusing to start")


@pytest.mark.parametrize(
    "content",
    [
        b'{"trip": NaN}',
        b'{"trip": 1e400}',
        b'{"trip": ' + b"9" * 5000 + b"}",
        b"[" * 100_000 + b"]" * 100_000,
        b'{"trip": 7, "kind": "\xff"}',
        b"",
        b"\x00" * 100,
        b" " * (65 << 10),
    ],
    ids=["nan", "inf", "5000-digits", "deep", "not-utf8", "empty", "nul", "over-64KiB"],
)
def test_a_file_that_is_not_json_of_numbers_refuses_the_start(
    tmp_path: Path, content: bytes
) -> None:
    path = tmp_path / "f.json"
    path.write_bytes(content)
    _refused(path, "refusing to start")


def test_a_device_or_a_fifo_refuses_the_start_at_once(tmp_path: Path) -> None:
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/zero")):
        with pytest.raises(FreshnessError, match="not a regular file"):
            read_trip(path, KEY)


def test_reset_keeps_the_old_file_and_never_goes_below_a_good_one(good: Path) -> None:
    damaged = b"{damaged"
    with pytest.raises(ConfigError, match=r"at trip 41: starting at 0 would reopen trips 1\.\.41"):
        reset_trip(good, KEY, 0, NOW)
    good.write_bytes(damaged)
    kept = reset_trip(good, KEY, 0, NOW)
    assert kept == good.with_name("freshness.json.replaced-20261126T120000Z")
    assert kept.read_bytes() == damaged
    assert read_trip(good, KEY) == 0
    with pytest.raises(ConfigError, match="exists already"):
        reset_trip(good, KEY, 5, NOW)  # a second reset in the same second keeps both
    assert reset_trip(good, KEY, 5, NOW + datetime.timedelta(seconds=1)) is not None
    with pytest.raises(ConfigError, match="--trip"):
        reset_trip(good, KEY, MAX_LOADED_TRIP + 1, NOW)


# --- the sender's file: the same rules for its numbers -----------------------------------------


def _sender(path: Path, fields: dict[str, Any]) -> FreshnessStore:
    path.write_bytes(state_bytes(KEY, freshness.KIND, fields))
    return FreshnessStore(KEY, path)


def test_a_senders_counters_at_their_edge_load_and_past_it_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "sender.json"
    store = _sender(path, {"trip": MAX_TRIP, "counters": {"257": MAX_COUNTER, "2047": 0}})
    assert (store.trip, store.bound(257), store.bound(2047)) == (MAX_TRIP, MAX_COUNTER, 0)
    for fields in (
        {"trip": MAX_TRIP + 1, "counters": {}},
        {"trip": -1, "counters": {}},
        {"trip": 3, "counters": {"257": MAX_COUNTER + 1}},
        {"trip": 3, "counters": {"257": -1}},
        {"trip": 3, "counters": {"2048": 1}},
        {"trip": 3, "counters": {"x": 1}},
        {"trip": 3, "counters": {"257": 1.5}},
        {"trip": 3, "counters": []},
        {"trip": 3},
    ):
        with pytest.raises(ConfigError, match="move it away"):
            _sender(path, fields)


def test_a_damaged_or_foreign_sender_file_is_refused_and_a_missing_one_starts_afresh(
    tmp_path: Path,
) -> None:
    path = tmp_path / "sender.json"
    assert FreshnessStore(KEY, path).trip == 0
    FreshnessStore(OTHER_KEY, path).adopt(3)
    with pytest.raises(ConfigError, match="of another key"):
        FreshnessStore(KEY, path)
    path.write_text("{")
    with pytest.raises(ConfigError, match="not JSON"):
        FreshnessStore(KEY, path)


def test_a_senders_file_always_covers_what_was_used(tmp_path: Path) -> None:
    path = tmp_path / "sender.json"
    store = FreshnessStore(KEY, path, block=8)
    store.adopt(9)
    for value in range(1, 200):
        store.reserve(0x101, value)
        on_disk = FreshnessStore(KEY, path).bound(0x101)
        assert value <= on_disk <= value + 16
    store.close()


# --- full and read-only disks: nothing started, nothing left -----------------------------------


@pytest.mark.parametrize("broken", ["full", "read-only"])
def test_a_start_on_a_full_or_read_only_disk_is_refused_and_leaves_nothing(
    tmp_path: Path, broken: str
) -> None:
    with small_tmpfs(tmp_path / "state") as state:
        path = state / "freshness.json"
        reset_trip(path, KEY, 41, NOW)
        if broken == "full":
            fill(state)
        else:
            read_only(state)
        for _ in range(100):
            with pytest.raises(FreshnessError) as refusal:
                start_trip(path, KEY)
            assert "cannot write the freshness file: " in str(refusal.value)
            assert "refusing to start" in str(refusal.value)
        assert read_trip(path, KEY) == 41
        assert entries(state) == {"freshness.json"}


def test_a_sender_on_a_full_disk_stops_signing_and_leaves_nothing(tmp_path: Path) -> None:
    with small_tmpfs(tmp_path / "state") as state:
        signer = SecocSigner(KEY, FreshnessStore(KEY, state / "sender.json", block=8))
        for frame_id, data in SecocReceiver(KEY, 5, dbc.command_ids()).announcement:
            signer.hear(frame_id, data)
        assert signer.authenticator(0x101, bytes(8)) is not None
        fill(state)
        signed = [signer.authenticator(0x101, bytes(8)) for _ in range(1000)]
        covered = sum(1 for pdu in signed if pdu is not None)
        assert covered <= 8  # what the last durable block covers, never a value past it
        assert signed[-1] is None
        assert entries(state) == {"sender.json"}
        signer.close()
        assert FreshnessStore(KEY, state / "sender.json").bound(0x101) >= 1 + covered
