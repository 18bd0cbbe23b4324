"""A control for the cost of looking: the same kind of load on the other CPU, with no feed at all.

The looking phases add processes beside the controller: the telemetry writer and a Foxglove
client. On a two-CPU machine they share the other CPU with the controller's own helper threads.
This script stands in for them with no feed, no socket and no shared memory: a niceness-10
process that encodes JSON for `--busy-ms` and then sleeps for `--idle-ms`, about 17 % of a CPU by
default, near what the writer and the client take together (RESULTS run P, `perf sched`). Run a
plain bench with it and without it, and compare the nominal phases:

    PYTHONPATH=src .venv/bin/python bench/other_load.py &
    .venv/bin/bywire bench --duration 20 --realtime --config bench/realtime.toml --json
    kill %1

Whatever the nominal phase loses with this load running is the machine's answer to any work on
the other CPU. It is not a cost of the feed's design (RESULTS run Q).
"""

from __future__ import annotations

import argparse
import json
import os
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--busy-ms", type=float, default=2.0)
    parser.add_argument("--idle-ms", type=float, default=10.0)
    args = parser.parse_args()
    os.nice(10)  # as the writer process and the dashboard's view
    body = {f"field_{k}": [k * 0.1, "text" * 3, {"a": k, "b": [1.5, 2.5]}] for k in range(80)}
    while True:
        end = time.perf_counter() + args.busy_ms / 1000
        while time.perf_counter() < end:
            json.dumps(body)
        time.sleep(args.idle_ms / 1000)


if __name__ == "__main__":
    main()
