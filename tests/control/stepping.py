"""Test helper: run the pure decision over a list of (now, inputs) as the shell would feed it.

The shell counts RC and ControlCommand frames and takes the ControlCommand's edges between
consecutive frames; here a slot whose stamp changed from the previous step is a new frame, and
a remote stop's rising edge between them a stop request (the reader also counts one in any
intact frame, trusted or not: a test sets `stop_requests` for that).
Controller tests use a debounce of one frame unless they test the debounce itself.
"""

from __future__ import annotations

from dataclasses import replace

from bywire.control.command_edges import command_edges
from bywire.control.controller import ControlConfig, ControlInputs, ControlOutputs, ControlState
from bywire.control.controller import controller_step as step
from bywire.control.supervisor import SupervisorConfig
from bywire.model import ControlCommand

CONFIG = ControlConfig(supervisor=SupervisorConfig(debounce_frames=1))

Steps = list[tuple[float, ControlInputs]]


def framed(steps: Steps) -> Steps:
    """The steps with frame counts and edges filled in, as the runtime's readers do."""
    previous, rc_frames, control_frames, result = ControlInputs(), 0, 0, []
    stop_requests = 0
    for now, inputs in steps:
        edges = inputs.control_edges
        if inputs.rc is not None and (
            previous.rc is None or inputs.rc.received_at != previous.rc.received_at
        ):
            rc_frames += 1
        control, before = inputs.commands.get(ControlCommand), previous.commands.get(ControlCommand)
        if control is not None and (before is None or control.received_at != before.received_at):
            control_frames += 1
            edges = command_edges(None if before is None else before.value, control.value)
            stop_requests += edges.remote_stop
        counted = replace(
            inputs,
            rc_frames=rc_frames,
            control_frames=control_frames,
            control_edges=edges,
            stop_requests=max(stop_requests, inputs.stop_requests),
        )
        result.append((now, counted))
        previous = counted
    return result


def run(steps: Steps, config: ControlConfig | None = None) -> list[ControlOutputs]:
    """Every step's outputs, from power-up."""
    state, outputs = ControlState(), []
    for now, inputs in framed(steps):
        state, output = step(state, inputs, now, config or CONFIG)
        outputs.append(output)
    return outputs
