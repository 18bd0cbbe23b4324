"""One picture of the running controller, read from a `/bywire/state` message of the telemetry
feed: the dashboard's model. Pure: a decoded message in, a frozen snapshot out.

The dashboard never touches the controller: it is a client of the feed (Foxglove's WebSocket
protocol), in a process of its own, and this is all it knows of the robot.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

SOURCES = {
    "none": "none: STOP holds full brake",
    "rc": "RC transmitter (IBUS)",
    "can": "CAN (higher-level computer)",
}


@dataclass(frozen=True, slots=True)
class CommandView:
    """The movement set-point the actuators follow (after the interlocks) and its source."""

    source: str
    steering_norm: float
    throttle_norm: float
    brake_norm: float
    gear: str


@dataclass(frozen=True, slots=True)
class ActuatorView:
    """Every actuator level the controller commands (the DAC's acknowledged volts if known)."""

    steering_pulse_ms: float
    throttle_volts: float
    dac_throttle_volts: float | None
    regen_volts: float
    hydrobrake_duty: float
    ebrake_engaged: bool
    motors_enabled: bool
    direction: str  # forward, reverse or neutral
    lights_on: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class InputView:
    """How fresh the inputs are and what arrived; ages None until first seen."""

    rc_age_s: float | None
    can_movement_age_s: float | None
    rc_frames: int
    can_control_frames: int
    reports_sent: int
    telemetry_dropped: int


@dataclass(frozen=True, slots=True)
class TaskView:
    """One row of the schedule table (the thesis' Figure 30, with rates and jitter)."""

    name: str
    nominal_rate_hz: float
    rate_hz: float
    runtime_share_pct: float
    jitter_max_ms: float
    overruns: int
    budget_exceeded: int


@dataclass(frozen=True, slots=True)
class DashboardSnapshot:
    """The whole dashboard at one instant; `elapsed_s` is controller time since it started."""

    elapsed_s: float
    mode: str
    armed: bool
    latched: tuple[str, ...]
    direction_change_held: bool
    speed_mps: float | None
    command: CommandView
    actuators: ActuatorView
    inputs: InputView
    error_flags: tuple[str, ...]
    tasks: tuple[TaskView, ...]
    idle_share_pct: float  # 100 % minus the tasks' runtime shares (Figure 30's IDLE row)
    watchdog_tripped: bool
    speed_limit_mps: float | None = None  # `[limits] max_speed_mps` (None: no limit)
    speed_limited: bool = False  # the governor acts: throttle held below what was asked, or braking


def from_state(state: Mapping[str, Any]) -> DashboardSnapshot:
    """The dashboard of one decoded `/bywire/state` message (KeyError if it is not one)."""
    elapsed_s = float(state["elapsed_s"])
    setpoint, outputs, inputs = state["setpoint"], state["outputs"], state["inputs"]
    tasks = tuple(_task(task, elapsed_s) for task in state["tasks"])
    lights = outputs["lights"]
    direction = "forward" if outputs["forward"] else "reverse" if outputs["reverse"] else "neutral"
    return DashboardSnapshot(
        elapsed_s=elapsed_s,
        mode=state["mode"],
        armed=bool(state["armed"]),
        latched=tuple(state["latched_causes"]),
        direction_change_held=bool(state["direction_change_held"]),
        speed_mps=state["speed_mps"],
        command=CommandView(
            source=SOURCES.get(state["setpoint_source"], state["setpoint_source"]),
            steering_norm=setpoint["steering_norm"],
            throttle_norm=setpoint["throttle_norm"],
            brake_norm=setpoint["brake_norm"],
            gear=setpoint["gear"],
        ),
        actuators=ActuatorView(
            steering_pulse_ms=outputs["steering_pulse_ms"],
            throttle_volts=outputs["throttle_volts"],
            dac_throttle_volts=outputs["dac_throttle_volts"],
            regen_volts=outputs["regen_volts"],
            hydrobrake_duty=outputs["hydrobrake_duty"],
            ebrake_engaged=outputs["ebrake_engaged"],
            motors_enabled=outputs["motors_enabled"],
            direction=direction,
            lights_on=tuple(name for name, on in lights.items() if on),
        ),
        inputs=InputView(
            rc_age_s=inputs["rc_age_s"],
            can_movement_age_s=inputs["can_movement_age_s"],
            rc_frames=inputs["rc_frames"],
            can_control_frames=inputs["can_control_frames"],
            reports_sent=state["reports_sent"],
            telemetry_dropped=state["telemetry_dropped"],
        ),
        error_flags=tuple(state["error_flags"]),
        tasks=tasks,
        idle_share_pct=max(0.0, 100.0 - sum(task.runtime_share_pct for task in tasks)),
        watchdog_tripped=bool(state["watchdog_tripped"]),
        speed_limit_mps=state["speed_limit"]["limit_mps"],
        speed_limited=bool(state["speed_limit"]["acting"]),
    )


def _task(task: Mapping[str, Any], elapsed_s: float) -> TaskView:
    return TaskView(
        name=task["name"],
        nominal_rate_hz=task["nominal_rate_hz"],
        rate_hz=task["rate_hz"],
        runtime_share_pct=100.0 * task["spent_s"] / elapsed_s if elapsed_s > 0 else 0.0,
        jitter_max_ms=task["max_jitter_ms"],
        overruns=task["overruns"],
        budget_exceeded=task["budget_exceeded"],
    )
