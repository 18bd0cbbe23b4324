"""Run the controller again on a run record's inputs, in virtual time, and compare its outputs.

The real `Runtime` (readers and codecs included) runs on the playback ports
(`bywire.hal.tape.playback`) under taped ports (`bywire.hal.tape.taped`); what it writes is
compared instant by instant with what the record holds (`bywire.replay.divergence`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from bywire.config import RobotConfig, parse_config
from bywire.config.security_setup import controller_receiver, simulated_run_key
from bywire.hal.simulated.clock import VirtualClock
from bywire.hal.simulated.timers import PeriodicTimer
from bywire.hal.tape.playback import replay_hardware
from bywire.hal.tape.run_record import Output, RecordedRun, outputs_of
from bywire.hal.tape.taped import Tape, taped_hardware
from bywire.replay.divergence import Divergence, first_divergence
from bywire.runtime.loop import Runtime
from bywire.runtime.settings import RuntimeConfig
from bywire.runtime.watchdog import POLL_S as WATCHDOG_POLL_S
from bywire.security.session import SecocReceiver


@dataclass(frozen=True, slots=True)
class ReplayResult:
    """The recorded and the replayed outputs, and the first divergence (None: identical)."""

    recorded: list[Output]
    replayed: list[Output]
    divergence: Divergence | None


def recorded_robot(record: RecordedRun) -> RobotConfig:
    """The robot configuration the run was recorded with."""
    return parse_config(record.header.config_toml, "the run record's configuration")


def _receiver(record: RecordedRun) -> SecocReceiver | None:
    """An authenticated run's verifier, as the simulated run built it: the recorded robot's key
    (its key file, or the one drawn from its seed), freshness in memory from zero."""
    if not record.header.authenticated:
        return None
    security = recorded_robot(record).security
    key = simulated_run_key(security, recorded_robot(record).sim.seed)
    return controller_receiver(dataclasses.replace(security, freshness_file=None), key)


def replay(record: RecordedRun, robot: RobotConfig | None = None) -> ReplayResult:
    """Run the controller on the record's inputs (with `robot`, default: the recorded one)."""
    robot = recorded_robot(record) if robot is None else robot
    clock = VirtualClock(record.header.start_s)
    tape = Tape(clock)
    hardware = taped_hardware(replay_hardware(record, clock), tape)
    # As the simulated run: the watchdog on the virtual clock, checked by a timer where its
    # thread would poll (a thread would only watch how fast the replay runs); a DAC write that
    # hung in the record hangs as long here, and the watchdog trips as it did.
    runtime = Runtime(
        hardware,
        RuntimeConfig.from_robot(robot),
        watchdog_thread=False,
        secoc=_receiver(record),
    )
    watchdog = runtime.watchdog
    if watchdog is not None:

        def check(_tick_s: float) -> None:
            watchdog.check()

        PeriodicTimer(clock, WATCHDOG_POLL_S, check).start()
    runtime.run(until_s=record.header.end_s)
    replayed = outputs_of(tape.events)
    return ReplayResult(record.outputs, replayed, first_divergence(record.outputs, replayed))
