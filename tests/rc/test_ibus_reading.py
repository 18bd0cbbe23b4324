"""The view's reading of a stream: the controller's parser and decoding, and what it shows."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from bywire.config import RobotConfig
from bywire.control.rc_mapping import RcMapping
from bywire.hal.simulated.rc_transmitter import idle_channels
from bywire.protocol import ibus
from bywire.rc.ibus_reading import RcSession
from bywire.rc.view import reads_as, rows, status

MAPPING = RcMapping()


def _frame(**changes: int) -> bytes:
    channels = list(idle_channels(MAPPING))
    for name, raw in changes.items():
        channels[getattr(MAPPING, name).channel] = raw
    return ibus.encode_frame(channels)


def _bad_checksum(frame: bytes) -> bytes:
    return frame[:-1] + bytes([frame[-1] ^ 0x01])


def _session(*frames: bytes) -> RcSession:
    session = RcSession(RobotConfig())
    session.feed(b"".join(frames), 1.0)
    return session


def test_frames_with_a_bad_checksum_are_counted_dropped_and_shown() -> None:
    good = _frame(mode_switch=1500)
    session = _session(good, _bad_checksum(_frame(mode_switch=2000)), good)
    assert session.parser.stats.frames == 2
    assert session.parser.stats.checksum_errors >= 1
    assert session.seen.channels[MAPPING.mode_switch.channel].max_raw == 1500
    assert "checksum errors" in status(session, "pty", None, 1.0).plain
    assert status(session, "pty", None, 1.0).plain.count("0 checksum errors") == 0


@given(st.lists(st.one_of(st.binary(max_size=40), st.sampled_from([_frame()])), max_size=30))
def test_any_byte_stream_is_read_without_an_error(chunks: list[bytes]) -> None:
    session = RcSession(RobotConfig())
    for chunk in chunks:
        session.feed(chunk, 0.5)
    assert session.parser.stats.frames >= chunks.count(_frame()) - 1
    assert len(rows(session, session.suggestion())) == ibus.CHANNEL_COUNT


def test_a_mode_switch_between_positions_reads_as_stop() -> None:
    session = _session(_frame(mode_switch=1250))
    assert reads_as("mode_switch", session).plain == "between positions: STOP"
    assert reads_as("mode_switch", _session(_frame(mode_switch=2000))).plain == "CAN"


def test_the_hysteresis_holds_a_position_read_at_a_bands_edge() -> None:
    edge = 1500 + MAPPING.mode_switch.band_raw + 10  # past RC's band, inside its hysteresis
    assert reads_as("mode_switch", _session(_frame(mode_switch=edge))).plain.startswith("between")
    held = _session(_frame(mode_switch=1500), _frame(mode_switch=edge))
    assert reads_as("mode_switch", held).plain == "RC"


def test_a_new_gear_shows_as_debouncing_until_it_counts() -> None:
    session = _session(_frame(gear_switch=2000))
    assert reads_as("gear_switch", session).plain == "FORWARD (debouncing; NEUTRAL now)"
    frames = [_frame(gear_switch=2000)] * RobotConfig().supervisor.debounce_frames
    assert reads_as("gear_switch", _session(*frames)).plain == "FORWARD"


def test_sticks_read_normalised_and_failsafe_frames_are_refused() -> None:
    session = _session(_frame(steering=1750, throttle_brake=1250))
    assert reads_as("steering", session).plain == "+0.50"
    assert reads_as("throttle_brake", session).plain == "brake 0.50"
    failsafe = _session(_frame(throttle_brake=MAPPING.failsafe.below_raw - 50))
    assert reads_as("steering", failsafe).plain == "frame refused (failsafe): STOP"
    assert failsafe.seen.failsafe_frames == 1


def test_the_status_names_a_silent_source() -> None:
    silent = RcSession(RobotConfig())
    assert "no frame yet" in status(silent, "pty", None, 1.0).plain
    stale = _session(_frame())
    assert "no frame for 2.0 s" in status(stale, "pty", "lost", 3.0).plain
    assert status(stale, "pty", "lost", 3.0).plain.endswith("; lost")
