"""The Linux clock (monotonic, woken by input threads) and the sd_notify helper."""

from __future__ import annotations

import contextlib
import socket
import threading
from pathlib import Path

import pytest

from bywire.hal.linux.clock import LinuxClock
from bywire.hal.linux.systemd import notify


def test_a_notification_from_another_thread_ends_a_long_wait() -> None:
    clock = LinuxClock()
    deadline_s = clock.now() + 60.0
    threading.Timer(0.01, clock.notify_input).start()
    clock.wait_until(deadline_s)
    assert clock.now() < deadline_s


def test_a_notification_before_the_wait_is_not_lost_and_is_used_once() -> None:
    clock = LinuxClock()
    clock.notify_input()
    clock.wait_until(clock.now() + 60.0)  # returns at once: the input came while busy
    start_s = clock.now()
    clock.wait_until(start_s + 0.001)
    assert clock.now() >= start_s + 0.001  # the flag was cleared: this wait ran to its deadline


def test_a_deadline_in_the_past_returns_at_once() -> None:
    clock = LinuxClock()
    before_s = clock.now()
    clock.wait_until(before_s - 1.0)
    assert clock.now() >= before_s


def test_notify_sends_the_state_to_the_notify_socket(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "notify"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as manager:
        manager.bind(str(path))
        monkeypatch.setenv("NOTIFY_SOCKET", str(path))
        notify("READY=1")
        assert manager.recv(64) == b"READY=1"


def test_notify_without_systemd_or_with_a_dead_socket_is_quiet(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("NOTIFY_SOCKET", raising=False)
    notify("READY=1")
    monkeypatch.setenv("NOTIFY_SOCKET", str(tmp_path / "gone"))
    notify("WATCHDOG=1")


def test_notify_never_waits_on_a_manager_that_stopped_reading(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "notify"
    with (
        socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as manager,
        socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as filler,
    ):
        manager.bind(str(path))
        filler.setblocking(False)
        with contextlib.suppress(BlockingIOError):
            while True:  # fill the manager's queue: it never reads
                filler.sendto(b"STATUS=filler", str(path))
        monkeypatch.setenv("NOTIFY_SOCKET", str(path))
        sender = threading.Thread(target=notify, args=("WATCHDOG=1",), daemon=True)
        sender.start()
        sender.join(timeout=10.0)  # a guard against a hang, not a timing figure
        assert not sender.is_alive(), "notify blocked on a full notify socket"
