"""Ctrl-C on `bywire sim --realtime`, as a real child process: the run stops at once with safe
outputs, and the summary, the plot and a complete CAN log are written for the part that ran."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest

from bywire.dashboard.client import FeedClient

LIMIT_S = 60.0  # generous: a loaded machine is slow to import the simulator


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_stopped_realtime_run_writes_its_summary_plot_and_complete_log(
    tmp_path: Path, stop: signal.Signals
) -> None:
    plot, log = tmp_path / "run.png", tmp_path / "run.blf"
    command = [sys.executable, "-m", "bywire", "sim", "--realtime", "--duration", "60"]
    command += ["--plot", str(plot), "--log", str(log), "--foxglove", "127.0.0.1:0"]
    process = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "COLUMNS": "120"},
    )
    try:
        assert process.stderr is not None
        ready = process.stderr.readline()  # printed once the run is set up
        found = re.search(r"ws://\S+", ready)
        assert found is not None, ready
        _wait_for_elapsed(found.group(), 1.0)  # it has run a while: frames both ways
        process.send_signal(stop)
        out, err = process.communicate(timeout=LIMIT_S)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 130, err
    assert "Traceback" not in err
    assert f"Stopped by {stop.name} after" in out
    assert re.search(r"Simulated \d+\.\d+ s", out)  # the summary of the part that ran
    assert plot.read_bytes().startswith(b"\x89PNG")
    with can.BLFReader(str(log)) as reader:
        frames = list(reader)
    assert len(frames) > 100  # 50 Hz reports and commands for over a second
    assert f"CAN log: {log} ({len(frames)} frames)" in " ".join(out.split())


def _wait_for_elapsed(url: str, elapsed_s: float) -> None:
    """Watch the run's telemetry feed until its controller has run `elapsed_s`."""
    client = FeedClient(url).start()
    try:
        deadline = time.monotonic() + LIMIT_S
        while (state := client.latest()) is None or state["elapsed_s"] < elapsed_s:
            assert not client.ended, client.status
            assert time.monotonic() < deadline, f"no state past {elapsed_s} s: {client.status}"
            time.sleep(0.05)
    finally:
        client.close()
