"""pyserial backend on a pty: IBUS at 115200-baud pacing parsed whole, the port vanishing and
coming back under the same name, clear errors, idempotent close."""

from __future__ import annotations

import errno
import termios
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from bywire.errors import HardwareError
from bywire.hal.linux.clock import LinuxClock
from bywire.hal.linux.serial_pyserial import PyserialStream
from bywire.model import ControlMode
from bywire.protocol.ibus import IbusParser
from tests.hal.linux.pty_rc import PtyRcLine

ATTEMPTS = 2000  # waits of at most 10 ms each: a generous bound, not a timing assertion


@pytest.fixture
def line(tmp_path: Path) -> Iterator[PtyRcLine]:
    rc = PtyRcLine(tmp_path / "ttyRC")
    yield rc
    rc.close()


def _wait(clock: LinuxClock, condition: Callable[[], bool]) -> bool:
    for _ in range(ATTEMPTS):
        if condition():
            return True
        clock.wait_until(clock.now() + 0.01)
    return False


def test_paced_ibus_frames_from_the_transmitter_parse_whole(line: PtyRcLine) -> None:
    clock = LinuxClock()
    stream = PyserialStream(str(line.link), clock.notify_input)
    parser, frames = IbusParser(), []
    line.transmitter.set_mode(ControlMode.RC)
    line.transmitter.set_steering(0.5)
    line.start()
    try:

        def twenty_parsed() -> bool:
            frames.extend(parser.feed(stream.read_available(), 0.0))
            return len(frames) >= 20

        assert _wait(clock, twenty_parsed)
    finally:
        stream.close()
    assert set(frames) == {line.transmitter.channels}
    assert parser.stats.checksum_errors == 0


def test_a_vanished_port_is_flagged_and_reopened_when_it_returns(line: PtyRcLine) -> None:
    clock = LinuxClock()
    stream = PyserialStream(str(line.link), clock.notify_input, reopen_period_s=0.02)
    try:
        line.unplug()
        assert _wait(clock, lambda: stream.fault is not None)
        assert "lost" in str(stream.fault)
        assert not stream.connected
        assert _wait(clock, lambda: stream.link.reopen_failures >= 2)  # still gone
        assert (stream.link.down, stream.link.receive_failures) == (True, 1)
        line.plug()
        assert _wait(clock, lambda: stream.connected)
        assert not stream.link.down
        line.write(b"\x20\x40back")
        received = bytearray()

        def all_received() -> bool:
            received.extend(stream.read_available())
            return received == b"\x20\x40back"

        assert _wait(clock, all_received)
        assert (stream.disconnects, stream.reopens) == (1, 1)
    finally:
        stream.close()


def test_a_tty_that_fails_as_it_is_opened_is_a_failed_reopen_not_a_dead_reader(
    line: PtyRcLine, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A tty whose far end had closed opened, then refused pyserial's flush with EIO (a
    termios.error, no OSError: seen under user-mode Linux, tests/kernel/test_faults.py). The
    reader thread died of it and never re-opened the port (shown on the old code: no failed
    re-open counted once the port was back, and a traceback on stderr)."""
    clock = LinuxClock()
    stream = PyserialStream(str(line.link), clock.notify_input, reopen_period_s=0.02)
    refusing = [True]
    flush = termios.tcflush

    def tcflush(fd: int, queue: int) -> None:
        if refusing[0]:
            raise termios.error(errno.EIO, "Input/output error")
        flush(fd, queue)

    try:
        monkeypatch.setattr(termios, "tcflush", tcflush)
        line.unplug()
        assert _wait(clock, lambda: stream.fault is not None)
        line.plug()
        failures = stream.link.reopen_failures
        assert _wait(clock, lambda: stream.link.reopen_failures >= failures + 2)
        assert stream.link.down
        refusing[0] = False
        assert _wait(clock, lambda: stream.connected)
    finally:
        stream.close()


def test_a_missing_port_says_how_to_make_it_appear(tmp_path: Path) -> None:
    with pytest.raises(HardwareError, match=r"ttyNONE does not exist: enable the UART"):
        PyserialStream(str(tmp_path / "ttyNONE"), lambda: None)


def test_a_port_in_use_is_refused(line: PtyRcLine) -> None:
    first = PyserialStream(str(line.link), lambda: None)
    try:
        with pytest.raises(HardwareError, match="in use by another process"):
            PyserialStream(str(line.link), lambda: None)
    finally:
        first.close()


def test_close_twice_stops_the_thread(line: PtyRcLine) -> None:
    stream = PyserialStream(str(line.link), lambda: None)
    stream.close()
    stream.close()
    assert not any(thread.name.startswith("rc-uart") for thread in threading.enumerate())
