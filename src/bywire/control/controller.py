"""The whole control decision in one pure step: stamped inputs and `now` in, every output level out.

The runtime calls `controller_step` whenever a valid input arrives (so a command reaches the
actuators at once) and on every periodic tick (so timeouts are checked every control cycle), then
writes the parts each task owns. Nothing here reads a clock or touches hardware.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bywire.control.drive import DriveConfig, DriveOutputs, drive_outputs
from bywire.control.error_flags import ErrorFlag
from bywire.control.hydrobrake import DEFAULT_THRESHOLD_NORM, hydrobrake_duty
from bywire.control.interlocks import InterlockConfig, InterlockState, interlock_step
from bywire.control.lights import BLINK_RATE_HZ, LightOutputs, LightRequest, light_outputs
from bywire.control.monitors import (
    MonitorConfig,
    MonitorInputs,
    MonitorState,
    monitor_step,
    stop_required,
)
from bywire.control.mux import Latch, Movement, MuxInputs, MuxState, movement_from, mux_step
from bywire.control.rc_mapping import RcMapping, RcRequest
from bywire.control.steering import SteeringConfig, SteeringState, steering_step
from bywire.control.validity import Stamped, fresh, is_fresh
from bywire.model import (
    ControlCommand,
    ControlMode,
    Gear,
    LightsCommand,
    MovementCommand,
)


@dataclass(frozen=True, slots=True)
class ControlConfig:
    """What the decision needs from the robot's configuration."""

    steering: SteeringConfig = field(default_factory=SteeringConfig)
    drive: DriveConfig = field(default_factory=DriveConfig)
    rc_mapping: RcMapping = field(default_factory=RcMapping)
    hydrobrake_threshold_norm: float = DEFAULT_THRESHOLD_NORM
    rc_timeout_s: float = 0.100
    can_command_timeout_s: float = 0.100
    blink_rate_hz: float = BLINK_RATE_HZ
    interlocks: InterlockConfig = field(default_factory=InterlockConfig)
    monitors: MonitorConfig = field(default_factory=MonitorConfig)


@dataclass(frozen=True, slots=True)
class ControlInputs:
    """The latest value of every input, stamped; None until first seen.

    `rc` holds None as its value when the last frame was intact but implausible (failsafe flags,
    a channel out of range): that counts as a lost link at once, not after the timeout.
    `fault_flags` are the conditions only the shell can see (DAC writes, CAN transmit, overruns);
    `hardware_fault` says one of them demands STOP.
    """

    rc: Stamped[RcRequest | None] | None = None
    movement: Stamped[MovementCommand] | None = None
    lights: Stamped[LightsCommand] | None = None
    control: Stamped[ControlCommand] | None = None
    fault_flags: int = 0
    hardware_fault: bool = False
    speed_mps: float | None = None  # signed, positive forward; None without a speed sensor
    hydrobrake_pressure_bar: float | None = None  # None without a pressure sensor
    steering_measured_norm: float | None = None  # None without a steering encoder


@dataclass(frozen=True, slots=True)
class ControlState:
    """What the decision remembers between steps."""

    mux: MuxState = field(default_factory=MuxState)
    steering: SteeringState = field(default_factory=SteeringState)
    interlock: InterlockState = field(default_factory=InterlockState)
    monitor: MonitorState = field(default_factory=MonitorState)
    hydrobrake_duty: float = 1.0  # as applied by the previous step: what the pressure answers to


@dataclass(frozen=True, slots=True)
class ControlOutputs:
    """Every output level at one instant, and why."""

    mode: ControlMode
    latch: Latch | None
    movement: Movement  # after the interlocks: what the actuators follow
    direction_change_held: bool
    steering_pulse_s: float
    drive: DriveOutputs
    hydrobrake_duty: float
    ebrake_engaged: bool
    lights: LightOutputs
    light_request: LightRequest
    error_flags: int


def _mux_inputs(
    inputs: ControlInputs, now: float, config: ControlConfig, monitor_stop: bool
) -> MuxInputs:
    rc = fresh(inputs.rc, now, config.rc_timeout_s)
    control = fresh(inputs.control, now, config.can_command_timeout_s)
    return MuxInputs(
        rc=rc,
        can_movement=fresh(inputs.movement, now, config.can_command_timeout_s),
        remote_stop=control is not None and control.remote_stop,
        re_enable=control is not None and control.re_enable,
        hardware_fault=inputs.hardware_fault or monitor_stop,
    )


def _monitor(
    state: ControlState, inputs: ControlInputs, now: float, config: ControlConfig
) -> tuple[MonitorState, ErrorFlag]:
    """Feedback against what the actuators were last told (the previous step's outputs)."""
    monitor_inputs = MonitorInputs(
        hydro_duty=state.hydrobrake_duty,
        pressure_bar=inputs.hydrobrake_pressure_bar,
        steering_command_norm=state.steering.setpoint_norm,
        steering_measured_norm=inputs.steering_measured_norm,
    )
    return monitor_step(state.monitor, monitor_inputs, now, config.monitors)


def _input_flags(inputs: ControlInputs, mux: MuxInputs, now: float, config: ControlConfig) -> int:
    flags = ErrorFlag(0)
    if not is_fresh(inputs.rc, now, config.rc_timeout_s):
        flags |= ErrorFlag.RC_TIMEOUT
    elif mux.rc is None:
        flags |= ErrorFlag.RC_FAILSAFE
    if mux.rc is not None and mux.rc.mode is ControlMode.CAN and mux.can_movement is None:
        flags |= ErrorFlag.CAN_COMMAND_TIMEOUT
    if mux.remote_stop:
        flags |= ErrorFlag.REMOTE_STOP
    return int(flags)


def _light_request(
    mode: ControlMode, mux: MuxInputs, lights: LightsCommand | None, movement: Movement, flags: int
) -> LightRequest:
    rc_lights = mux.rc if mode is ControlMode.RC else None
    can_lights = lights if mode is ControlMode.CAN else None
    return LightRequest(
        brake_norm=movement.brake_norm,
        reverse_gear=movement.gear is Gear.REVERSE,
        error_flags=flags,
        turn_left=can_lights is not None and can_lights.turn_left,
        turn_right=can_lights is not None and can_lights.turn_right,
        hazard=(can_lights is not None and can_lights.hazard)
        or (rc_lights is not None and rc_lights.hazard),
        low_beam=(can_lights is not None and can_lights.low_beam)
        or (rc_lights is not None and rc_lights.low_beam),
    )


def controller_step(
    state: ControlState, inputs: ControlInputs, now: float, config: ControlConfig
) -> tuple[ControlState, ControlOutputs]:
    """One decision: monitors, mode, interlocks, then every actuator level."""
    monitor, monitor_flags = _monitor(state, inputs, now, config)
    mux_inputs = _mux_inputs(inputs, now, config, stop_required(monitor_flags, config.monitors))
    mux = mux_step(state.mux, mux_inputs)
    interlock, movement, held = interlock_step(
        state.interlock,
        movement_from(mux.mode, mux_inputs),
        inputs.speed_mps,
        now,
        config.interlocks,
    )
    driving = mux.mode is not ControlMode.STOP
    # In STOP the steering holds where it is: centring at speed would be a swerve.
    target_norm = movement.steering_norm if driving else state.steering.setpoint_norm
    steering, pulse_s = steering_step(
        state.steering, target_norm, now, config.steering, inputs.steering_measured_norm
    )
    flags = inputs.fault_flags | _input_flags(inputs, mux_inputs, now, config) | monitor_flags
    lights_command = fresh(inputs.lights, now, config.can_command_timeout_s)
    light_request = _light_request(mux.mode, mux_inputs, lights_command, movement, flags)
    duty = hydrobrake_duty(movement.brake_norm, config.hydrobrake_threshold_norm)
    outputs = ControlOutputs(
        mode=mux.mode,
        latch=mux.latch,
        movement=movement,
        direction_change_held=held,
        steering_pulse_s=pulse_s,
        drive=drive_outputs(movement, enabled=driving, config=config.drive),
        hydrobrake_duty=duty,
        ebrake_engaged=not driving,
        lights=light_outputs(light_request, now, config.blink_rate_hz),
        light_request=light_request,
        error_flags=flags,
    )
    return ControlState(mux, steering, interlock, monitor, duty), outputs
