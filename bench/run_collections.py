"""Garbage collections inside `bywire run` itself, with no simulator sharing its heap.

The benchmark's real-time session runs the simulated robot in the controller's process, so its
collections also scan the simulator's and the bench's own objects. This runs `bywire run` on the
Linux stand-ins of the tests (fake gpiod, sysfs PWM, IIO DAC, an RC receiver on a pty sending a
frame every 7 ms, a higher-level computer sending a MovementCommand every 20 ms on a virtual CAN
bus), armed in CAN mode, with `[realtime]` FIFO 40, memory locked and `gc_mode = "idle"`, and
reports every collection after start-up: generation and CPU time.

    PYTHONPATH=src .venv/bin/python bench/run_collections.py --seconds 60

The higher-level computer runs as a thread of the same process (python-can's virtual bus lives in
one process), so its objects are in the heap too: an upper bound for a robot.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))  # for the stand-ins in tests/

from tests.cli.test_run import LAUNCHER  # noqa: E402
from tests.hal.linux.bench import make_bench  # noqa: E402
from tests.hal.linux.pty_rc import PtyRcLine  # noqa: E402

from bywire.bench.stats import percentile  # noqa: E402
from bywire.model import ControlMode  # noqa: E402

START_UP_S = 3.0  # collections before this (imports, building the runtime) are not the loop's
REALTIME = '\n[realtime]\nscheduler = "fifo"\npriority = 40\nlock_memory = true\ngc_mode = "idle"\n'
# Run inside the child: note each collection, write them out at exit, then run the launcher.
METER = r"""
import atexit, gc, json, runpy, sys, time
out, seen, started = sys.argv.pop(1), [], [0.0]
def note(phase, info):
    if phase == "start":
        started[0] = time.thread_time()
    else:
        seen.append((time.monotonic(), info["generation"], time.thread_time() - started[0]))
gc.callbacks.append(note)
atexit.register(lambda: json.dump(seen, open(out, "w")))
sys.argv = sys.argv[1:]
runpy.run_path(sys.argv[0], run_name="__main__")
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="armed time to meter")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        bench = make_bench(root)
        line = PtyRcLine.at_rest(bench.rc_link)
        hlc = root / "hlc"
        hlc.mkdir()
        movement = {"steering": 0.1, "throttle": 0.0, "brake": 0.3, "gear": "forward"}
        (hlc / "movement.json").write_text(json.dumps(movement))
        config = root / "robot.toml"
        config.write_text(bench.config_text() + REALTIME)
        out = root / "collections.json"
        run = ["run", "--config", str(config), "--sysfs-root", str(bench.sysfs)]
        run += ["--dev-root", str(bench.dev)]
        command = [sys.executable, "-c", METER, str(out), str(LAUNCHER), str(hlc)]
        command += [bench.can_channel, "--", *run]
        env = {**os.environ, "PYTHONPATH": str(REPOSITORY / "src")}
        child = subprocess.Popen(
            command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
        )
        try:
            time.sleep(START_UP_S)
            line.transmitter.set_mode(ControlMode.CAN)
            print(f"metering {args.seconds:g} s of the loop…", file=sys.stderr)
            time.sleep(args.seconds)
            child.send_signal(signal.SIGTERM)
            _, err = child.communicate(timeout=30)
        finally:
            line.close()
            if child.poll() is None:
                child.kill()
        lines = err.decode().splitlines()
        print(next((text for text in lines if "real-time:" in text), "no real-time line"))
        seen = json.loads(out.read_text())
    first_s = seen[0][0] if seen else 0.0
    loop = [(generation, cpu_s) for at_s, generation, cpu_s in seen if at_s > first_s + START_UP_S]
    print(f"{len(seen) - len(loop)} collections during start-up, {len(loop)} in the loop")
    by_generation: dict[int, list[float]] = defaultdict(list)
    for generation, cpu_s in loop:
        by_generation[generation].append(cpu_s)
    for generation, spent in sorted(by_generation.items()):
        p50_s, max_s = percentile(spent, 0.5), max(spent)
        print(
            f"  generation {generation}: {len(spent)},"
            f" p50 {p50_s * 1e3:.3f} ms, max {max_s * 1e3:.3f} ms"
        )
    return 0 if child.returncode == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
