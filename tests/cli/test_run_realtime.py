"""`bywire run` applies the [realtime] settings it is permitted and warns, naming the fix, about
the rest; a refusal never stops the robot. The process runs the simulated backend as user nobody
(through setpriv when the tests run as root) with RLIMIT_RTPRIO at 0, so the kernel refuses."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src"
LIMIT_S = 30.0
CONFIG = """
backend = "sim"
[realtime]
scheduler = "fifo"
priority = 30
lock_memory = true
cpus = "{cpu}"
"""
# `bywire run` with RLIMIT_RTPRIO and RLIMIT_MEMLOCK lowered first (allowed to anyone).
LAUNCH = (
    "import resource, runpy, sys; "
    "resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0)); "
    "resource.setrlimit(resource.RLIMIT_MEMLOCK, (65536, 65536)); "
    "sys.argv = ['bywire', *sys.argv[1:]]; "
    "runpy.run_module('bywire.cli.main', run_name='__main__')"
)


@pytest.mark.skipif(
    os.geteuid() == 0 and shutil.which("setpriv") is None, reason="root, and no setpriv to drop it"
)
def test_refused_settings_are_warnings_with_their_fix_and_the_robot_runs() -> None:
    cpu = max(os.sched_getaffinity(0))
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        root.chmod(0o755)
        config = root / "robot.toml"
        config.write_text(CONFIG.format(cpu=cpu), encoding="utf-8")
        config.chmod(0o644)
        command = [sys.executable, "-c", LAUNCH, "run", "--config", str(config)]
        if os.geteuid() == 0:
            command = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", *command]
        process = subprocess.Popen(
            command,
            stderr=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            text=True,
            env={**os.environ, "PYTHONPATH": str(SRC)},
            cwd="/",
        )
        assert process.stderr is not None
        lines: list[str] = []
        deadline_s = time.monotonic() + LIMIT_S
        while not any("running" in line for line in lines) and time.monotonic() < deadline_s:
            line = process.stderr.readline()
            if not line:
                break
            lines.append(line)
        process.send_signal(signal.SIGTERM)
        status = process.wait(timeout=LIMIT_S)
        lines += process.stderr.read().splitlines(keepends=True)
    text = "".join(lines)
    warnings = [line for line in lines if " WARNING " in line]
    assert status == 0, text
    assert len(warnings) == 2, text
    assert "SCHED_FIFO 30 refused: EPERM" in warnings[1]
    assert "LimitRTPRIO=30" in warnings[1]
    assert "mlockall refused: RLIMIT_MEMLOCK is 65536 bytes" in warnings[0]
    assert "LimitMEMLOCK=infinity" in warnings[0]
    [summary] = [line for line in lines if "real-time: applied" in line]
    assert f"applied CPUs {cpu}, gc.freeze (" in summary
    assert "refused mlockall (" in summary
    assert "SCHED_FIFO 30 (EPERM" in summary
    assert "Traceback" not in text
