"""One frozen picture of the running controller, taken in its loop thread: the dashboard's model.

Everything here reads the runtime's mutable state, so `snapshot` must run in the loop's own thread
(an `on_cycle` observer); the result is immutable and safe to hand to any other thread. The task
table reuses `bywire sim`'s rows, so the dashboard and the summary agree to the digit.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from bywire.control.controller import ControlOutputs
from bywire.control.error_flags import flag_names
from bywire.control.validity import age_s
from bywire.model import ControlMode
from bywire.runtime.app import Runtime
from bywire.sim.summary import TaskRow, task_row

SOURCES = {
    ControlMode.STOP: "none: STOP holds full brake",
    ControlMode.RC: "RC transmitter (IBUS)",
    ControlMode.CAN: "higher-level computer (CAN movement command)",
}


@dataclass(frozen=True, slots=True)
class ModeView:
    """The selected mode and, while STOP is latched, every cause and why; armed: nothing
    latched."""

    mode: str
    latch: str | None
    latch_reason: str | None
    armed: bool
    direction_change_held: bool


@dataclass(frozen=True, slots=True)
class CommandView:
    """The movement set-point the actuators follow (after the interlocks) and its source."""

    source: str
    steering_norm: float
    throttle_norm: float
    brake_norm: float
    gear: str


@dataclass(frozen=True, slots=True)
class InputView:
    """How fresh the inputs are and what the readers counted; ages None until first seen."""

    rc_age_s: float | None
    can_movement_age_s: float | None
    ibus_frames: int
    ibus_checksum_errors: int
    ibus_resyncs: int
    can_rejected: tuple[tuple[str, int], ...]  # (reason, count), reasons seen only
    reports_sent: int


@dataclass(frozen=True, slots=True)
class ActuatorView:
    """Every actuator level the controller commands."""

    steering_pulse_ms: float
    throttle_volts: float
    regen_volts: float
    hydrobrake_duty: float
    ebrake_engaged: bool
    motors_enabled: bool
    direction: str  # forward, reverse or neutral
    lights_on: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class DashboardSnapshot:
    """The whole dashboard at one instant; `elapsed_s` is controller time since it started."""

    elapsed_s: float
    wall_elapsed_s: float
    mode: ModeView
    command: CommandView
    inputs: InputView
    actuators: ActuatorView
    error_flags: tuple[str, ...]
    tasks: tuple[TaskRow, ...]
    idle_share_pct: float  # 100 % minus the tasks' runtime shares (Figure 30's IDLE row)
    watchdog_tripped: bool


def snapshot(runtime: Runtime, now: float, wall_elapsed_s: float) -> DashboardSnapshot:
    """The dashboard of `runtime` at `now`; call it from the loop's thread, after a decision.

    Raises ValueError before the first decision (the loop takes one on its first pass).
    """
    outputs = runtime.outputs
    if outputs is None:
        raise ValueError("the controller has not taken a decision yet")
    elapsed_s = now - runtime.started_at
    tasks = tuple(task_row(task, elapsed_s, wall_elapsed_s) for task in runtime.tasks)
    causes = sorted(outputs.causes, key=lambda cause: cause.name)
    movement = outputs.movement
    return DashboardSnapshot(
        elapsed_s=elapsed_s,
        wall_elapsed_s=wall_elapsed_s,
        mode=ModeView(
            mode=outputs.mode.name,
            latch=", ".join(cause.name for cause in causes) or None,
            latch_reason="; ".join(cause.value for cause in causes) or None,
            armed=not causes,
            direction_change_held=outputs.direction_change_held,
        ),
        command=CommandView(
            source=SOURCES[outputs.mode],
            steering_norm=movement.steering_norm,
            throttle_norm=movement.throttle_norm,
            brake_norm=movement.brake_norm,
            gear=movement.gear.name,
        ),
        inputs=_inputs(runtime, now),
        actuators=_actuators(outputs),
        error_flags=tuple(flag_names(outputs.error_flags)),
        tasks=tasks,
        idle_share_pct=max(0.0, 100.0 - sum(task.runtime_share_pct for task in tasks)),
        watchdog_tripped=runtime.watchdog is not None and runtime.watchdog.tripped,
    )


def _inputs(runtime: Runtime, now: float) -> InputView:
    parser = runtime.ibus.parser.stats
    rejected = sorted((reason.value, n) for reason, n in runtime.can.rejected.items() if n)
    return InputView(
        rc_age_s=age_s(runtime.inputs.rc, now),
        can_movement_age_s=age_s(runtime.inputs.movement, now),
        ibus_frames=parser.frames,
        ibus_checksum_errors=parser.checksum_errors,
        ibus_resyncs=parser.resyncs,
        can_rejected=tuple(rejected),
        reports_sent=runtime.reports_sent,
    )


def _actuators(outputs: ControlOutputs) -> ActuatorView:
    drive, lights = outputs.drive, outputs.lights
    direction = "forward" if drive.forward else "reverse" if drive.reverse else "neutral"
    return ActuatorView(
        steering_pulse_ms=outputs.steering_pulse_s * 1000.0,
        throttle_volts=drive.throttle_volts,
        regen_volts=drive.regen_volts,
        hydrobrake_duty=outputs.hydrobrake_duty,
        ebrake_engaged=outputs.ebrake_engaged,
        motors_enabled=drive.enable,
        direction=direction,
        lights_on=tuple(f.name for f in fields(lights) if getattr(lights, f.name)),
    )
