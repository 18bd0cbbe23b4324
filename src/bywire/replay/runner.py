"""Run the controller again on a run record's inputs, in virtual time, and compare its outputs.

The real `Runtime` (readers and codecs included) runs on the playback ports
(`bywire.hal.tape.playback`) under taped ports (`bywire.hal.tape.taped`); what it writes is
compared instant by instant with what the record holds (`bywire.replay.divergence`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from bywire.config import RobotConfig, parse_config
from bywire.hal.sim.clock import VirtualClock
from bywire.hal.tape.playback import replay_hardware
from bywire.hal.tape.run_record import Output, RecordedRun, outputs_of
from bywire.hal.tape.taped import Tape, taped_hardware
from bywire.replay.divergence import Divergence, first_divergence
from bywire.runtime.app import Runtime
from bywire.runtime.settings import RuntimeConfig


@dataclass(frozen=True, slots=True)
class ReplayResult:
    """The recorded and the replayed outputs, and the first divergence (None: identical)."""

    recorded: list[Output]
    replayed: list[Output]
    divergence: Divergence | None


def recorded_robot(record: RecordedRun) -> RobotConfig:
    """The robot configuration the run was recorded with."""
    return parse_config(record.header.config_toml, "the run record's configuration")


def replay(record: RecordedRun, robot: RobotConfig | None = None) -> ReplayResult:
    """Run the controller on the record's inputs (with `robot`, default: the recorded one)."""
    robot = recorded_robot(record) if robot is None else robot
    clock = VirtualClock(record.header.start_s)
    tape = Tape(clock)
    hardware = taped_hardware(replay_hardware(record, clock), tape)
    # Virtual time: a watchdog thread would only watch how fast the replay runs.
    config = dataclasses.replace(RuntimeConfig.from_robot(robot), watchdog_s=None)
    Runtime(hardware, config).run(until_s=record.header.end_s)
    replayed = outputs_of(tape.events)
    return ReplayResult(record.outputs, replayed, first_divergence(record.outputs, replayed))
