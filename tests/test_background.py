"""The one owner of bywire's threads and processes: it ends what runs, newest first, on every way
out of a scope, within a bounded wait, and names what did not end."""

from __future__ import annotations

import functools
import subprocess
import sys
import threading

import pytest

from bywire.background import Owner

SLEEPER = [sys.executable, "-c", "import time; time.sleep(60)"]
DEAF = [
    sys.executable,
    "-c",
    "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); print(1, flush=True);"
    " time.sleep(60)",
]


def test_a_scope_ends_its_work_newest_first_on_an_exception() -> None:
    owner = Owner()
    ended: list[str] = []
    stops = {name: threading.Event() for name in ("first", "second")}

    def stopper(name: str) -> None:
        ended.append(name)
        stops[name].set()

    started: list[subprocess.Popen[bytes]] = []

    def command() -> None:
        with owner.scope():
            for name, stop in stops.items():
                owner.thread(stop.wait, name=name, stop=functools.partial(stopper, name))
            started.append(owner.popen(SLEEPER, name="sleeper"))
            raise RuntimeError("the command failed")

    with pytest.raises(RuntimeError):
        command()
    assert started[0].poll() is not None  # terminated
    assert ended == ["second", "first"]
    assert owner.running() == []


def test_a_scope_ends_its_work_on_ctrl_c() -> None:
    owner = Owner()
    started: list[subprocess.Popen[bytes]] = []

    def command() -> None:
        with owner.scope():
            started.append(owner.popen(SLEEPER, name="sleeper"))
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        command()
    assert started[0].poll() is not None


def test_work_started_before_the_scope_is_not_its_own() -> None:
    owner = Owner()
    outer = owner.popen(SLEEPER, name="outer")
    with owner.scope():
        inner = owner.popen(SLEEPER, name="inner")
    assert inner.poll() is not None
    assert outer.poll() is None
    assert owner.end_all() == []
    assert outer.poll() is not None


def test_a_process_deaf_to_sigterm_is_killed_after_its_grace() -> None:
    owner = Owner()
    process = owner.popen(DEAF, name="deaf", grace_s=0.1, stdout=subprocess.PIPE)
    assert process.stdout is not None
    process.stdout.readline()  # its SIGTERM is ignored from here on
    assert owner.end_all() == []
    assert process.wait() == -9  # SIGKILL
    process.stdout.close()


def test_a_thread_that_does_not_end_is_named_with_where_it_started(
    capsys: pytest.CaptureFixture[str],
) -> None:
    owner = Owner()
    release = threading.Event()
    owner.thread(release.wait, name="stubborn", join_s=0.01)  # no stop callback: it cannot end
    left = owner.end_all()
    release.set()
    assert [work.name for work in left] == ["stubborn"]
    line = capsys.readouterr().err
    assert "thread 'stubborn' (started at " in line
    assert "tests/test_background.py:" in line
    assert "did not end" in line


def test_ended_work_is_forgotten() -> None:
    owner = Owner()
    thread = owner.thread(lambda: None, name="short")
    thread.join()
    assert owner.running() == []
