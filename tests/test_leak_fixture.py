"""The leak check (tests/leaks.py) fails a test that leaves a thread or a process running, names
the leak, and kills the process (issue 42)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

pytest_plugins = ["pytester"]

ROOT = Path(__file__).resolve().parent.parent

LEAKING = """
import subprocess, sys, threading

from bywire.background import OWNER

HOLD = threading.Event()

def test_leaks_a_thread():
    threading.Thread(target=HOLD.wait, name="leaky-thread", daemon=True).start()

PARENT = (
    "import subprocess, sys, time;"
    " p = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(61)'],"
    " start_new_session=True); print(p.pid, flush=True); time.sleep(60)"
)

def test_leaks_a_process_and_its_child(tmp_path_factory):
    child = subprocess.Popen([sys.executable, "-c", PARENT], stdout=subprocess.PIPE, text=True)
    grandchild = child.stdout.readline().strip()
    (tmp_path_factory.getbasetemp() / "pids").write_text(f"{child.pid} {grandchild}")

def test_leaks_owned_work():
    OWNER.thread(HOLD.wait, name="leaky-owned")

def test_ends_what_it_starts():
    done = threading.Event()
    thread = threading.Thread(target=done.wait, name="tidy", daemon=True)
    thread.start()
    done.set()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
"""


def test_a_leak_fails_the_test_names_it_and_kills_the_process(
    pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PYTHONPATH", f"{ROOT}{os.pathsep}{ROOT / 'src'}")
    pytester.makeconftest("from tests.leaks import no_leaks  # noqa: F401\n")
    pytester.makepyfile(test_leaking=LEAKING)
    base = pytester.path / "t"
    leaking = pytester.runpytest_subprocess("-p", "no:randomly", "--basetemp", str(base))
    leaking.assert_outcomes(passed=4, errors=3)  # the tidy test passes; each leak is an error
    leaking.stdout.fnmatch_lines(
        [
            "*ERROR at teardown of test_leaks_a_thread*",
            "*left running after the test: thread 'leaky-thread'*",
            "*ERROR at teardown of test_leaks_a_process_and_its_child*",
            "*left running after the test: process * (*Popen*); process * (*time.sleep(61))*",
            "*ERROR at teardown of test_leaks_owned_work*",
            "*left running after the test: thread 'leaky-owned' (started at *test_leaking.py:*)*",
        ]
    )
    for pid in map(int, (base / "pids").read_text().split()):
        assert not Path(f"/proc/{pid}").exists() or _zombie(pid)  # killed, not left to live on


def _zombie(pid: int) -> bool:
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
