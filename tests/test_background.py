"""The one owner of bywire's threads and processes: it ends what runs, newest first, on every way
out of a scope, within a bounded wait, and names what did not end."""

from __future__ import annotations

import ast
import functools
import multiprocessing
import re
import subprocess
import sys
import threading

import pytest

from bywire.background import OWNER, Owner
from tests.layers import SOURCE

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


STARTERS = re.compile(
    r"threading\.Thread\(|subprocess\.(Popen|run|call|check_call|check_output)\(|\.Pool\(|"
    r"\bProcess\(|os\.fork\(|_thread\.start_new"
)
HANDED_TO_THE_OWNER = {
    ("ros2/link_process.py", "Process("),  # made here, started by OWNER.process
    ("sim/verify/engine.py", "Process("),  # verify's workers: made here, started by OWNER.process
}


def test_nothing_in_bywire_starts_a_thread_or_a_process_but_the_owner() -> None:
    """Issue 42: one owner; a new starter anywhere else fails here, naming its line."""
    elsewhere = [
        f"{path.relative_to(SOURCE)}:{number}: {line.strip()}"
        for path in sorted(SOURCE.rglob("*.py"))
        if path.name != "background.py" or path.parent != SOURCE
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if (found := STARTERS.search(line)) is not None
        and not line.lstrip().startswith("#")
        and (str(path.relative_to(SOURCE)), found.group(0)) not in HANDED_TO_THE_OWNER
    ]
    assert elsewhere == []


def test_every_owned_thread_and_process_is_named_as_bywire_s() -> None:
    """A leak's line, `ps -T` and py-spy say whose it is: every name given to the owner starts
    with `bywire-`."""
    unnamed = []
    for path in sorted(SOURCE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and isinstance(node.func.value, ast.Name)
                and node.func.value.id == "OWNER"
                and node.func.attr in ("thread", "popen")
            ):
                continue
            name = next((k.value for k in node.keywords if k.arg == "name"), None)
            text = ast.unparse(name) if name is not None else ""
            if not text.lstrip("f").strip("'\"").startswith("bywire-"):
                unnamed.append(f"{path.relative_to(SOURCE)}:{node.lineno}: {text or 'no name'}")
    assert unnamed == []


def test_work_that_ends_before_the_scope_does_hides_nothing_started_inside() -> None:
    owner = Owner()
    done = threading.Event()
    earlier = owner.thread(done.wait, name="earlier", stop=done.set)
    with owner.scope():
        inner = owner.popen(SLEEPER, name="inner")
        done.set()
        earlier.join()  # the owner's list shrinks while the scope is open
    assert inner.poll() is not None


def _owned_here() -> int:
    return len(OWNER.running())


def test_a_forked_child_owns_none_of_its_parent_s_work() -> None:
    """A forked worker (verify's pool) must not end, or wait on, its parent's work: work whose
    liveness a child cannot tell (adopted, its own `alive`) is forgotten at the fork."""
    ended = threading.Event()

    def end(_wait_s: float | None) -> bool:
        ended.set()
        return True

    work = OWNER.adopt("process", "bywire-test-parent", alive=lambda: not ended.is_set(), end=end)
    try:
        with multiprocessing.get_context("fork").Pool(1) as pool:
            assert pool.apply(_owned_here) == 0
    finally:
        ended.set()
        OWNER.forget(work)


def test_each_work_is_waited_for_its_own_bound_unless_capped() -> None:
    """A child that finishes a file (the telemetry writer) gets its own grace at a command's
    end, not a shorter common one; the leak check caps it."""
    owner = Owner()
    waits: list[float | None] = []

    def end(wait_s: float | None) -> bool:
        waits.append(wait_s)
        return True

    for cap in (None, 0.0):
        owner.adopt("process", "bywire-test", alive=lambda: True, end=end)
        owner.end_all(owner.mark() - 1, cap)
        owner.forget(owner.running()[-1])
    assert waits == [None, 0.0]


def test_a_stop_that_fails_is_named_and_the_rest_still_end(
    capsys: pytest.CaptureFixture[str],
) -> None:
    owner = Owner()
    process = owner.popen(SLEEPER, name="older")
    release = threading.Event()

    def refuse() -> None:
        raise OSError("the port is gone")

    owner.thread(release.wait, name="refusing", stop=refuse, join_s=0.01)
    left = owner.end_all()
    release.set()
    assert [work.name for work in left] == ["refusing"]
    assert process.poll() is not None  # ended all the same
    assert "ending thread 'refusing'" in capsys.readouterr().err
