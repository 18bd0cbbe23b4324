"""Recording a simulated run changes nothing it does, and every record replays identically.

Issue 32: the recorder rebuilt the controller with a wall-clock watchdog thread and without the
SecOC verifier, and the virtual-time watchdog watched the controller that never ran: with
`--record`, `dac-stall-watchdog` passed 2 of 5 expectations (the watchdog never tripped), and the
records of that run and of an authenticated run diverged on replay.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from bywire.config import default_sim_config
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.hal.tape.run_record import read_record
from bywire.replay.recorder import SimRunRecorder
from bywire.replay.runner import replay
from bywire.sim.catalog import find_scenario
from bywire.sim.runner import SimRun


def _played(scenario: str, record: Path | None) -> tuple[dict[str, Any], list[bool | None]]:
    """What the simulated hardware did (every line's history, the DAC's, every CAN frame) and
    the verdicts, with or without a recorder attached."""
    run = SimRun(default_sim_config(), find_scenario(scenario))
    recorder = None if record is None else SimRunRecorder.attach(run, record)
    frames: list[LoggedFrame] = []
    run.add_can_monitor(frames.append)
    run.run()
    if recorder is not None:
        recorder.write()
    world = run.world
    hardware = {
        "gpio": {name: list(line.history) for name, line in world.gpio.items()},
        "pwm": [list(world.pwm.steering.history), list(world.pwm.hydrobrake.history)],
        "dac": list(world.dac.history),
        "can": [(f.time_s, f.arbitration_id, f.data, f.sender) for f in frames],
    }
    return hardware, [verdict.passed for verdict in run.record.verdicts]


@pytest.mark.parametrize(
    "scenario",
    [
        "dac-stall-watchdog",  # the watchdog trips inside a write hung in simulated time
        "can-impostor-authenticated",  # the controller verifies SecOC authenticators
    ],
)
def test_a_recorded_run_does_what_the_plain_run_does_and_its_record_replays_identically(
    scenario: str, tmp_path: Path
) -> None:
    plain, plain_verdicts = _played(scenario, None)
    recorded, verdicts = _played(scenario, tmp_path / "run.jsonl")
    assert all(plain_verdicts)
    assert verdicts == plain_verdicts
    assert recorded == plain
    record = read_record(tmp_path / "run.jsonl")
    result = replay(record)
    assert result.divergence is None
    assert len(result.replayed) == len(record.outputs) > 1000
