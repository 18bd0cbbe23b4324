"""A child process that uses a robot file the way bywire does and prints which values it read.

Usage: python read_child.py sim CONFIG.toml SCENARIO...   (the simulator and `bywire verify`)
       python read_child.py run CONFIG.toml ROOT CHANNEL  (`bywire run` on the stand-in devices)

The recorder (`tests.config.reads`) goes onto the configuration as bywire loads it. `sim` plays
the scenarios and two verify campaigns on that robot; `run` is `bywire run --config` on the
stand-ins of `tests.hal.linux.bench` under ROOT (fake gpiod, fake sysfs PWM and IIO DAC, the RC
receiver on a pty, a python-can virtual channel), stopped by SIGTERM after `RUN_S`. The output is
one JSON object: {"reads": [...], "unread": [...]}. A child, because `bywire run` applies the
real-time settings (scheduler, locked memory, CPUs) to its own process.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for `tests`
from tests.config.reads import Recorder
from tests.hal.linux import fake_gpiod

RUN_S = 1.5
recorder = Recorder()


def _recorded_loader(load: Any) -> Any:
    def load_and_record(path: Path | str) -> Any:
        config = load(path)
        recorder.install(config)
        return config

    return load_and_record


def simulate(config_path: str, scenarios: list[str]) -> Any:
    from bywire.config import load_config  # noqa: PLC0415
    from bywire.sim.catalog import find_scenario  # noqa: PLC0415
    from bywire.sim.runner import SimRun  # noqa: PLC0415
    from bywire.sim.verify.draw import draw_campaign  # noqa: PLC0415
    from bywire.sim.verify.engine import run_campaign  # noqa: PLC0415

    config = _recorded_loader(load_config)(config_path)
    for name in scenarios:
        SimRun(config, find_scenario(name)).run()
    for index in range(2):
        run_campaign(config, draw_campaign(0, index), index)
    return config


def run(config_path: str, root: str, channel: str) -> Any:
    sys.modules["gpiod"] = fake_gpiod
    from bywire.cli import run as run_command  # noqa: PLC0415
    from bywire.cli.main import main  # noqa: PLC0415
    from tests.hal.linux.pty_rc import PtyRcLine  # noqa: PLC0415

    loaded: list[Any] = []

    def load(path: Path | str) -> Any:
        config = recorded(path)
        loaded.append(config)
        return config

    namespace = vars(run_command)  # `bywire run` loads through the name it imported
    recorded = _recorded_loader(namespace["load_config"])
    namespace["load_config"] = load
    line = PtyRcLine(Path(root) / "ttyRC")
    threading.Timer(RUN_S, os.kill, (os.getpid(), signal.SIGTERM)).start()
    try:
        status = main(
            [
                "run",
                "--config",
                config_path,
                "--sysfs-root",
                f"{root}/sys",
                "--dev-root",
                f"{root}/dev",
            ]
        )
    finally:
        line.close()
    if status != 0:
        raise SystemExit(f"bywire run exited {status}")
    del channel  # named in the configuration; the argument documents which one
    return loaded[0]


if __name__ == "__main__":
    mode, config_file, *rest = sys.argv[1:]
    used = simulate(config_file, rest) if mode == "sim" else run(config_file, *rest)
    print(json.dumps({"reads": sorted(recorder.reads), "unread": sorted(recorder.unread(used))}))
