"""The start stall and the stop of `bywire run` with and without `--dashboard`, measured.

``python bench/run_start_stall.py [--seconds S] [--dashboard]`` runs ``bywire run`` on a
simulated-backend configuration on a pseudo-terminal (as an operator's terminal: 80x24, read
all the time), records its telemetry feed with ``--mcap``, sends SIGTERM after S seconds and
prints: the 100 Hz tasks' worst start jitter and overruns at the first state message (the first
pass: the issue's "start stall"), the same over the whole run, and the time from SIGTERM to the
process's exit. The figures come from the controller's own task statistics in the MCAP.
"""

from __future__ import annotations

import argparse
import fcntl
import json
import os
import pty
import signal
import struct
import subprocess
import sys
import tempfile
import termios
import threading
import time
from pathlib import Path

from mcap.reader import make_reader

CONFIG = 'name = "dry-run"\nbackend = "sim"\n'


def _states(path: Path) -> list[dict[str, object]]:
    with path.open("rb") as stream:
        reader = make_reader(stream)
        return [json.loads(m.data) for _s, _c, m in reader.iter_messages(topics=["/bywire/state"])]


def _control(state: dict[str, object]) -> tuple[float, int]:
    """(worst 100 Hz start jitter in ms, overruns of the 100 Hz tasks) so far."""
    tasks = [task for task in state["tasks"] if task["nominal_rate_hz"] == 100.0]  # type: ignore[attr-defined]
    return max(task["max_jitter_ms"] for task in tasks), sum(task["overruns"] for task in tasks)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--dashboard", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        config, mcap = Path(folder) / "dry.toml", Path(folder) / "run.mcap"
        config.write_text(CONFIG)
        master, slave = pty.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
        command = [sys.executable, "-m", "bywire", "run", "--config", str(config)]
        command += ["--mcap", str(mcap), *(["--dashboard"] if args.dashboard else [])]
        process = subprocess.Popen(
            command,
            stdin=slave,
            stdout=slave,
            stderr=slave,
            env={**os.environ, "TERM": "xterm-256color"},
            start_new_session=True,
        )
        os.close(slave)
        threading.Thread(target=_discard, args=(master,), daemon=True).start()
        time.sleep(args.seconds)
        signalled = time.monotonic()
        process.send_signal(signal.SIGTERM)
        status = process.wait(30)
        stop_s = time.monotonic() - signalled
        states = _states(mcap)
    first_ms, first_overruns = _control(states[0])
    whole_ms, whole_overruns = _control(states[-1])
    view = "with --dashboard" if args.dashboard else "without a view"
    print(
        f"bywire run {view}, {states[-1]['elapsed_s']:.1f} s: first pass: 100 Hz jitter"
        f" {first_ms:.2f} ms, {first_overruns} overruns; whole run: jitter max {whole_ms:.2f} ms,"
        f" {whole_overruns} overruns; SIGTERM to exit {stop_s * 1000:.0f} ms (status {status})"
    )


def _discard(master: int) -> None:
    try:
        while os.read(master, 65536):
            pass
    except OSError:
        return


if __name__ == "__main__":
    main()
