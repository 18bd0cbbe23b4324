"""A child process's bywire with one more row in its schedule table: a beeper line task.

`python -m tests.beeper_row` loads `bywire.task_table` from its own source with a beeper task
added the way a maintainer adds one (a function, and a row naming its line), before anything else of
bywire is imported, so every table derived from the schedule (the hardware bundle's lines, the
robot file's keys, the write gate, the safe state) derives the beeper too. It then drives the
simulated robot and the configuration loader and prints what it saw as JSON, for
`tests/test_task_table.py` to judge: nothing here asserts.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from itertools import pairwise
from pathlib import Path

BEEPER_FUNCTION = '''

def sound_beeper(target: TaskTarget, outputs: ControlOutputs, _now: float) -> None:
    """The reversing beeper: it sounds while the motors are driven in reverse."""
    reversing = outputs.drive.enable and outputs.drive.reverse
    target.actuators.write_lines("beeper", {"beeper": reversing})
'''
BEEPER_ROW = '    TaskSpec("beeper", 10.0, 0.002, sound_beeper, lines=("beeper",)),\n'
FUNCTION_BEFORE = "\n\ndef send_reports("
ROW_BEFORE = '    TaskSpec("can_tx"'


def install_beeper_row() -> None:
    """`bywire.task_table` from its source with the beeper's function and row added."""
    spec = importlib.util.find_spec("bywire.task_table")
    if spec is None or spec.origin is None:
        raise SystemExit("tests/beeper_row.py: bywire.task_table has no source file")
    text = Path(spec.origin).read_text()
    if FUNCTION_BEFORE not in text or ROW_BEFORE not in text:
        raise SystemExit("tests/beeper_row.py: the schedule table's layout changed; update me")
    text = text.replace(FUNCTION_BEFORE, BEEPER_FUNCTION + FUNCTION_BEFORE, 1)
    text = text.replace(ROW_BEFORE, BEEPER_ROW + ROW_BEFORE, 1)
    module = importlib.util.module_from_spec(spec)
    sys.modules["bywire.task_table"] = module
    exec(compile(text, spec.origin, "exec"), module.__dict__)


def observe() -> dict[str, object]:
    """What the beeper did on the simulated robot and in the loader."""
    from bywire.config import describe, output_lines, parse_config  # noqa: PLC0415
    from bywire.errors import ConfigError  # noqa: PLC0415
    from bywire.hal.simulated.clock import VirtualClock  # noqa: PLC0415
    from bywire.hal.simulated.world import SimWorld  # noqa: PLC0415
    from bywire.model import ControlMode, Gear  # noqa: PLC0415
    from bywire.runtime.actuators import ActuatorConfig, Actuators  # noqa: PLC0415
    from bywire.runtime.settings import RuntimeConfig  # noqa: PLC0415
    from tests.system.harness import Robot  # noqa: PLC0415

    robot = Robot.build()
    rc = robot.world.rc
    robot.arm_rc()
    robot.at(0.5, lambda: rc.set_gear(Gear.REVERSE))
    robot.at(0.6, lambda: rc.set_pedal(0.4))
    robot.at(2.0, lambda: rc.set_mode(ControlMode.STOP))
    writes: list[int] = []
    for tick in range(1, 21):  # the beeper's writes, sampled every 50 ms of the first second
        robot.at(tick * 0.05 + 0.001, lambda: writes.append(robot.world.gpio["beeper"].writes))
    robot.run(3.0)
    beeper = robot.world.gpio["beeper"]
    task = {task.spec.name: task for task in robot.runtime.tasks}["beeper"]

    world = SimWorld.create(VirtualClock())
    actuators = Actuators(world.hardware, ActuatorConfig())
    actuators.write_lines("beeper", {"beeper": True})
    before_trip = world.gpio["beeper"].level
    actuators.watchdog_trip()
    after_trip = world.gpio["beeper"].level
    actuators.write_lines("beeper", {"beeper": True})
    after_refused_write = world.gpio["beeper"].level

    line = '{ chip = "gpiochip1", line = "GPIO20" }'
    config = parse_config(f"[tasks]\nbeeper_rate_hz = 25\nbeeper_line = {line}\n")
    refusals = {}
    for name, text in {
        "not_a_line": "[tasks]\nbeeper_line = true\n",
        "error_led_line": '[tasks]\nbeeper_line = "ERROR_LED"\n',
    }.items():
        try:
            parse_config(text)
        except ConfigError as error:
            refusals[name] = str(error)
    configured = output_lines(config)["beeper"]
    rates = {spec.name: spec.rate_hz for spec in RuntimeConfig.from_robot(config).schedule}
    return {
        "rate_hz": task.spec.rate_hz,
        "runs": task.stats.runs,
        "writes_per_100_ms": [later - earlier for earlier, later in pairwise(writes[1::2])],
        "sounding_at": {f"{t:.2f}": beeper.level_at(t) for t in (0.45, 1.9, 2.15, 2.95)},
        "sounding_at_end": beeper.level,
        "trip": [before_trip, after_trip, after_refused_write],
        "configured_rate_hz": rates["beeper"],
        "configured_line": [configured.chip, configured.line],
        "round_trip": parse_config(describe(config)) == config,
        "described": [line for line in describe(config).splitlines() if "beeper" in line],
        "refusals": refusals,
    }


if __name__ == "__main__":
    install_beeper_row()
    print(json.dumps(observe()))
