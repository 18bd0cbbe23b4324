"""Every value of a robot file reaches code that uses it: none loads, validates and is ignored.

`bywire verify` checks the robot built from the user's numbers; a key that never reached the
simulator would have it check the default instead (`[sim] rc_frame_period_s` and `top_speed_mps`
were such keys until 2026-11-24). Two child processes use one robot file whose every section is
set the way bywire does: the simulator with its scenarios and verify's campaigns, and `bywire run`
on the stand-in devices; together they must read every value but those resolved at load. The
simulator plays it as a `sim` robot: the Linux backend fits no sensors yet, and a robot without
them has no use for the monitors' and the speed check's numbers.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from bywire.config import RobotConfig, default_sim_config
from bywire.runtime.settings import RuntimeConfig
from tests.config.reads import Recorder, leaves
from tests.hal.linux.bench import make_bench

CHILD = Path(__file__).with_name("read_child.py")
SCENARIOS = ("test-course", "can-impostor-authenticated")
RESOLVED_AT_LOAD = {
    "gpio_chip": "the chip of every line that names none: each line's own chip is read",
    "timeouts.can_command_timeout_s": "the limit of every CAN message that names none: each"
    " message's own limit (timeouts.can_message_timeout_s) is read",
    "timeouts.stop_response_s": "the stop promise the file declares: the load check holds the"
    " budgets to it (bywire.config.deadlines), and the runtime holds the work to the budgets",
}


def _child(*args: str) -> dict[str, Any]:
    done = subprocess.run(
        [sys.executable, str(CHILD), *args],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    result: dict[str, Any] = json.loads(done.stdout.splitlines()[-1])
    return result


def _robot_files(root: Path) -> tuple[Path, Path, str]:
    """A robot file for the stand-in devices with every optional section on, and the same
    robot on the simulator's backend."""
    bench = make_bench(root)
    key = root / "secoc.key"
    subprocess.run(
        [sys.executable, "-m", "bywire", "keys", "new", str(key)], check=True, capture_output=True
    )
    text = bench.config_text(
        more=f"""
[realtime]
scheduler = "fifo"
lock_memory = true
cpus = "0"
gc_mode = "idle"

[telemetry]
mcap = "{root}/feed.mcap"
foxglove = "127.0.0.1:0"

[security]
enabled = true
key_file = "{key}"
freshness_file = "{root}/freshness.json"
"""
    )
    path, simulated = root / "robot.toml", root / "simulated.toml"
    path.write_text(text)
    subprocess.run(
        [sys.executable, "-m", "bywire", "keys", "reset-freshness", "--config", str(path)],
        check=True,
        capture_output=True,
    )
    simulated.write_text(text.replace('backend = "linux"', 'backend = "sim"', 1))
    return path, simulated, bench.can_channel


@pytest.fixture(scope="module")
def unread(tmp_path_factory: pytest.TempPathFactory) -> set[str]:
    root = tmp_path_factory.mktemp("robot")
    robot_file, simulated_file, channel = _robot_files(root)
    simulated = _child("sim", str(simulated_file), *SCENARIOS)
    on_devices = _child("run", str(robot_file), str(root), channel)
    assert simulated["reads"]
    assert on_devices["reads"]
    return set(simulated["unread"]) & set(on_devices["unread"])


def test_every_value_is_read_by_the_simulator_or_the_robot(unread: set[str]) -> None:
    assert unread - set(RESOLVED_AT_LOAD) == set()


def test_the_values_resolved_at_load_are_the_only_ones_nothing_reads(unread: set[str]) -> None:
    assert unread == set(RESOLVED_AT_LOAD)


def test_a_value_counts_as_read_only_where_it_is_used() -> None:
    """The recorder's teeth: building the runtime reads the watchdog, not the scheduler; the
    loader's own reads never count."""
    config = default_sim_config()
    recorder = Recorder()
    recorder.install(config)
    try:
        RuntimeConfig.from_robot(config)
        assert "timeouts.watchdog_s" in recorder.reads
        assert "realtime.scheduler" not in recorder.reads
        before = set(recorder.reads)
        from bywire.config.render import describe  # noqa: PLC0415 -- a reader that doesn't count

        describe(config)
        assert recorder.reads == before
    finally:
        recorder.uninstall()
    assert "realtime.scheduler" in recorder.unread(config)
    assert leaves(RobotConfig()) == leaves(config)
