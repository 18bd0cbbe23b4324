"""The whole control decision in one pure step: stamped inputs and `now` in, every output level out.

The runtime calls `controller_step` whenever a valid input arrives (so a command reaches the
actuators at once) and on every periodic tick (so timeouts are checked every control cycle), then
writes the parts each task owns. Nothing here reads a clock or touches hardware.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Final, Protocol, TypeVar, cast

from bywire.command_table import (
    COMMANDS,
    MOVES_NOTHING,
    REQUESTS,
    CommandSpec,
    Use,
    command_row,
)
from bywire.control.command_edges import NO_EDGES, CommandEdges
from bywire.control.command_slots import NO_COMMANDS, CommandSlots
from bywire.control.drive import SAFE_DRIVE, DriveConfig, DriveOutputs, braking_drive, drive_outputs
from bywire.control.estop import NOT_PRESSED, EstopState, estop_step
from bywire.control.governor import (
    IDLE,
    GovernorConfig,
    GovernorState,
    acting,
    governed,
    governor_step,
)
from bywire.control.hydrobrake import DEFAULT_THRESHOLD_NORM, hydrobrake_duty
from bywire.control.interlocks import (
    InterlockConfig,
    InterlockState,
    can_throttle_allowed,
    interlock_step,
)
from bywire.control.lights import BLINK_RATE_HZ, LightOutputs, LightRequest, light_outputs
from bywire.control.mux import Movement, movement_from
from bywire.control.rc_mapping import RcMapping, RcRequest
from bywire.control.sensor_checks import (
    MonitorConfig,
    MonitorInputs,
    MonitorState,
    monitor_step,
    stopping_flags,
)
from bywire.control.speed_check import SpeedCheckState, cleared, speed_check_step, trusted_speed
from bywire.control.steering import (
    SteeringConfig,
    SteeringState,
    pulse_for_steering,
    steering_step,
)
from bywire.control.stop import (
    NOT_STOPPING,
    StopConfig,
    StopPhase,
    StopState,
    standstill_proven_since,
    stop_step,
)
from bywire.control.supervisor import (
    Cause,
    SupervisorConfig,
    SupervisorInputs,
    SupervisorState,
    counting,
    stop_category,
    supervisor_step,
)
from bywire.control.validity import Stamped, fresh, is_fresh
from bywire.control.values import slot_init
from bywire.error_flags import ErrorFlag
from bywire.model import (
    Command,
    ControlCommand,
    ControlMode,
    Gear,
    LightsCommand,
    MovementCommand,
    same_request,
)

MONITOR_CAUSES = (
    (ErrorFlag.HYDRO_PRESSURE_FAULT, Cause.HYDRO_PRESSURE),
    (ErrorFlag.STEERING_ENCODER_FAULT, Cause.STEERING_ENCODER),
)
RULES: dict[Use, type[Command]] = {
    Use.STOP_AND_RE_ENABLE: ControlCommand,
    Use.SET_POINTS: MovementCommand,
    Use.LIGHT_REQUESTS: LightsCommand,
}
"""The message each of the decision's own rules reads; `Use.REQUEST` rows are the tasks'."""


def check_rules(commands: tuple[CommandSpec, ...]) -> None:
    """TypeError unless each of the decision's own rules is the use of exactly its own message's
    row: a second set-point row, or set-points read from another message, would be ignored."""
    for use, kind in RULES.items():
        rows = [spec.kind for spec in commands if spec.use is use]
        if rows != [kind]:
            named = ", ".join(row.__name__ for row in rows) or "no row"
            raise TypeError(f"command table: {use.name} is {kind.__name__}'s rule, not {named}'s")


check_rules(COMMANDS)


@dataclass(frozen=True, slots=True)
class ControlConfig:
    """What the decision needs from the robot's configuration."""

    steering: SteeringConfig = field(default_factory=SteeringConfig)
    drive: DriveConfig = field(default_factory=DriveConfig)
    rc_mapping: RcMapping = field(default_factory=RcMapping)
    hydrobrake_threshold_norm: float = DEFAULT_THRESHOLD_NORM
    rc_timeout_s: float = 0.100
    # Each CAN command's own age limit (its receive check), by command row.
    command_timeouts_s: tuple[tuple[type[Command], float], ...] = tuple(
        (spec.kind, 0.100) for spec in COMMANDS
    )
    blink_rate_hz: float = BLINK_RATE_HZ
    interlocks: InterlockConfig = field(default_factory=InterlockConfig)
    monitors: MonitorConfig = field(default_factory=MonitorConfig)
    supervisor: SupervisorConfig = field(default_factory=SupervisorConfig)
    stop: StopConfig = field(default_factory=StopConfig)
    governor: GovernorConfig = field(default_factory=GovernorConfig)

    def command_timeout_s(self, kind: type[Command]) -> float:
        """The age limit of the CAN command `kind` (LookupError for a command without one)."""
        for timed, timeout_s in self.command_timeouts_s:
            if timed is kind:
                return timeout_s
        raise LookupError(f"no timeout for {kind.__name__}")


@dataclass(frozen=True, slots=True)
class ControlInputs:
    """The latest value of every input, stamped; None until first seen.

    `rc` holds None as its value when the last frame was intact but implausible (failsafe flags,
    a channel out of range): that counts as a lost link at once, not after the timeout.
    `commands` holds each CAN command message's newest frame, one slot per command row.
    `rc_frames` and `control_frames` count arrivals, so the decision sees which frame is new;
    `control_edges` are the edges the newest ControlCommand frame made (see `command_edges`);
    `stop_requests` counts remote stop requests that arrived, from any intact frame (the reader
    passes them whatever the counter or trust): a change is a remote stop arriving.
    `fault_flags` are the conditions only the shell can see (DAC writes, CAN transmit, overruns);
    `dac_failing`, `watchdog_tripped` and `timing_fault` are the shell's conditions that stop;
    `untrusted` names the command messages whose id is not trusted now: one whose row moves the
    robot stops CAN driving (CAN_UNTRUSTED), another costs its own function its requests.
    """

    rc: Stamped[RcRequest | None] | None = None
    commands: CommandSlots = NO_COMMANDS
    # ControlCommand's own rule (its row's `Use.STOP_AND_RE_ENABLE`), not a per-command list:
    # edges, arrivals and remote stop requests are what that rule needs beyond the newest frame
    # (a stop request counts even from a frame the slot would not keep). No other row has them.
    control_edges: CommandEdges = NO_EDGES
    rc_frames: int = 0
    control_frames: int = 0
    stop_requests: int = 0
    fault_flags: int = 0
    dac_failing: bool = False
    watchdog_tripped: bool = False
    untrusted: frozenset[type[Command]] = frozenset()
    timing_fault: bool = False
    speed_mps: float | None = None  # signed, positive forward; None without a speed sensor
    hydrobrake_pressure_bar: float | None = None  # None without a pressure sensor
    steering_measured_norm: float | None = None  # None without a steering encoder
    estop_line_high: bool | None = None  # the E-stop's line as read; None without an E-stop

    def __init__(  # noqa: PLR0917
        self,
        rc: Stamped[RcRequest | None] | None = None,
        commands: CommandSlots = NO_COMMANDS,
        control_edges: CommandEdges = NO_EDGES,
        rc_frames: int = 0,
        control_frames: int = 0,
        stop_requests: int = 0,
        fault_flags: int = 0,
        dac_failing: bool = False,
        watchdog_tripped: bool = False,
        untrusted: frozenset[type[Command]] = frozenset(),
        timing_fault: bool = False,
        speed_mps: float | None = None,
        hydrobrake_pressure_bar: float | None = None,
        steering_measured_norm: float | None = None,
        estop_line_high: bool | None = None,
    ) -> None:
        object.__setattr__(self, "rc", rc)
        object.__setattr__(self, "commands", commands)
        object.__setattr__(self, "control_edges", control_edges)
        object.__setattr__(self, "rc_frames", rc_frames)
        object.__setattr__(self, "control_frames", control_frames)
        object.__setattr__(self, "stop_requests", stop_requests)
        object.__setattr__(self, "fault_flags", fault_flags)
        object.__setattr__(self, "dac_failing", dac_failing)
        object.__setattr__(self, "watchdog_tripped", watchdog_tripped)
        object.__setattr__(self, "untrusted", untrusted)
        object.__setattr__(self, "timing_fault", timing_fault)
        object.__setattr__(self, "speed_mps", speed_mps)
        object.__setattr__(self, "hydrobrake_pressure_bar", hydrobrake_pressure_bar)
        object.__setattr__(self, "steering_measured_norm", steering_measured_norm)
        object.__setattr__(self, "estop_line_high", estop_line_high)


slot_init(ControlInputs)


# a new controller's memories (values: one of each is shared)
FRESH_SUPERVISOR: Final = SupervisorState()
FRESH_STEERING: Final = SteeringState()
FRESH_INTERLOCK: Final = InterlockState()
FRESH_MONITOR: Final = MonitorState()
FRESH_SPEED_CHECK: Final = SpeedCheckState()


@dataclass(frozen=True, slots=True)
class ControlState:
    """What the decision remembers between steps."""

    supervisor: SupervisorState = FRESH_SUPERVISOR
    steering: SteeringState = FRESH_STEERING
    interlock: InterlockState = FRESH_INTERLOCK
    monitor: MonitorState = FRESH_MONITOR
    speed_check: SpeedCheckState = FRESH_SPEED_CHECK
    hydrobrake_duty: float = 1.0  # as applied by the previous step: what the pressure answers to
    applied_throttle_norm: float = 0.0  # as applied by the previous step (0 while disabled)
    rc_frames_seen: int = 0
    control_frames_seen: int = 0
    stop_requests_seen: int = 0
    stop: StopState = NOT_STOPPING
    drive_applied: DriveOutputs = SAFE_DRIVE  # as the previous step left it
    estop: EstopState = NOT_PRESSED
    governor: GovernorState = IDLE

    def __init__(  # noqa: PLR0917
        self,
        supervisor: SupervisorState = FRESH_SUPERVISOR,
        steering: SteeringState = FRESH_STEERING,
        interlock: InterlockState = FRESH_INTERLOCK,
        monitor: MonitorState = FRESH_MONITOR,
        speed_check: SpeedCheckState = FRESH_SPEED_CHECK,
        hydrobrake_duty: float = 1.0,
        applied_throttle_norm: float = 0.0,
        rc_frames_seen: int = 0,
        control_frames_seen: int = 0,
        stop_requests_seen: int = 0,
        stop: StopState = NOT_STOPPING,
        drive_applied: DriveOutputs = SAFE_DRIVE,
        estop: EstopState = NOT_PRESSED,
        governor: GovernorState = IDLE,
    ) -> None:
        object.__setattr__(self, "supervisor", supervisor)
        object.__setattr__(self, "steering", steering)
        object.__setattr__(self, "interlock", interlock)
        object.__setattr__(self, "monitor", monitor)
        object.__setattr__(self, "speed_check", speed_check)
        object.__setattr__(self, "hydrobrake_duty", hydrobrake_duty)
        object.__setattr__(self, "applied_throttle_norm", applied_throttle_norm)
        object.__setattr__(self, "rc_frames_seen", rc_frames_seen)
        object.__setattr__(self, "control_frames_seen", control_frames_seen)
        object.__setattr__(self, "stop_requests_seen", stop_requests_seen)
        object.__setattr__(self, "stop", stop)
        object.__setattr__(self, "drive_applied", drive_applied)
        object.__setattr__(self, "estop", estop)
        object.__setattr__(self, "governor", governor)


slot_init(ControlState)


@dataclass(frozen=True, slots=True)
class ControlOutputs:
    """Every output level at one instant, and why."""

    mode: ControlMode
    causes: frozenset[Cause]  # latched: STOP until each one's own clearing rule fires
    movement: Movement  # after the supervisor's throttle gate and the interlocks
    direction_change_held: bool
    steering_pulse_s: float
    steering_hold_pulse_s: float  # the commanded position, without boost: what a trip holds
    stop_phase: StopPhase
    drive: DriveOutputs
    hydrobrake_duty: float
    ebrake_engaged: bool
    lights: LightOutputs
    light_request: LightRequest
    error_flags: int
    # Each `Use.REQUEST` row's request, fresh and trusted, in CAN mode (else None), for its task.
    requests: tuple[tuple[type[Command], Command | None], ...] = ()
    speed_limited: bool = False  # the governor holds the throttle below what was asked, or brakes

    def __init__(  # noqa: PLR0917
        self,
        mode: ControlMode,
        causes: frozenset[Cause],
        movement: Movement,
        direction_change_held: bool,
        steering_pulse_s: float,
        steering_hold_pulse_s: float,
        stop_phase: StopPhase,
        drive: DriveOutputs,
        hydrobrake_duty: float,
        ebrake_engaged: bool,
        lights: LightOutputs,
        light_request: LightRequest,
        error_flags: int,
        requests: tuple[tuple[type[Command], Command | None], ...] = (),
        speed_limited: bool = False,
    ) -> None:
        object.__setattr__(self, "mode", mode)
        object.__setattr__(self, "causes", causes)
        object.__setattr__(self, "movement", movement)
        object.__setattr__(self, "direction_change_held", direction_change_held)
        object.__setattr__(self, "steering_pulse_s", steering_pulse_s)
        object.__setattr__(self, "steering_hold_pulse_s", steering_hold_pulse_s)
        object.__setattr__(self, "stop_phase", stop_phase)
        object.__setattr__(self, "drive", drive)
        object.__setattr__(self, "hydrobrake_duty", hydrobrake_duty)
        object.__setattr__(self, "ebrake_engaged", ebrake_engaged)
        object.__setattr__(self, "lights", lights)
        object.__setattr__(self, "light_request", light_request)
        object.__setattr__(self, "error_flags", error_flags)
        object.__setattr__(self, "requests", requests)
        object.__setattr__(self, "speed_limited", speed_limited)

    def request(self, kind: type[C]) -> C | None:
        """What the command `kind` (a `Use.REQUEST` row) asks of its task now; None: nothing."""
        for requested, command in self.requests:
            if requested is kind:
                return cast(C | None, command)
        raise LookupError(f"{kind.__name__} is no request row")


slot_init(ControlOutputs)


@dataclass(frozen=True, slots=True)
class _Sources:
    """The inputs usable at one instant: None means missing, stale or invalid."""

    rc: RcRequest | None
    can_movement: MovementCommand | None
    control: ControlCommand | None
    lights: LightsCommand | None
    usable: dict[type[Command], Command | None]  # every command row's, by its `use`

    def __init__(
        self,
        rc: RcRequest | None,
        can_movement: MovementCommand | None,
        control: ControlCommand | None,
        lights: LightsCommand | None,
        usable: dict[type[Command], Command | None],
    ) -> None:
        object.__setattr__(self, "rc", rc)
        object.__setattr__(self, "can_movement", can_movement)
        object.__setattr__(self, "control", control)
        object.__setattr__(self, "lights", lights)
        object.__setattr__(self, "usable", usable)


slot_init(_Sources)


def _sources(inputs: ControlInputs, now: float, config: ControlConfig) -> _Sources:
    usable = {spec.kind: _usable(spec, inputs, now, config) for spec in COMMANDS}
    return _Sources(
        rc=fresh(inputs.rc, now, config.rc_timeout_s),
        can_movement=cast(MovementCommand | None, usable.get(MovementCommand)),
        control=cast(ControlCommand | None, usable.get(ControlCommand)),
        lights=cast(LightsCommand | None, usable.get(LightsCommand)),
        usable=usable,
    )


def _usable(
    spec: CommandSpec, inputs: ControlInputs, now: float, config: ControlConfig
) -> Command | None:
    """A command row's request as its `use` takes it: fresh, within the row's timeout. While its
    id is untrusted (another sender), light requests hold the last trusted one whatever its age
    (the lights alone are affected), and a task's request (`Use.REQUEST`) is dropped; set-points
    and stop requests keep their own rules (CAN_UNTRUSTED stops CAN driving)."""
    slot = inputs.commands.get(spec.kind)
    if spec.kind in inputs.untrusted:
        if spec.use is Use.LIGHT_REQUESTS and slot is not None:
            return slot.value
        if spec.use is Use.REQUEST:
            return None
    return fresh(slot, now, config.command_timeout_s(spec.kind))


def _requests(
    mode: ControlMode, sources: _Sources
) -> tuple[tuple[type[Command], Command | None], ...]:
    """Each request row's request for its task: in CAN mode alone."""
    can = mode is ControlMode.CAN
    return tuple((spec.kind, sources.usable[spec.kind] if can else None) for spec in REQUESTS)


def _untrusted_moves(untrusted: frozenset[type[Command]]) -> bool:
    """Among these untrusted ids, one of a command that moves the robot (CAN_UNTRUSTED)."""
    return any(command_row(kind).moves_the_robot for kind in untrusted)


def trust_changed(seen: ControlInputs, untrusted: frozenset[type[Command]]) -> bool:
    """Whether the ids not trusted now (`untrusted`) differ from those the decision saw in a
    way it tells apart: whether any that moves the robot is among them, and which others."""
    if untrusted == seen.untrusted:
        return False
    return _untrusted_moves(untrusted) != _untrusted_moves(seen.untrusted) or (
        untrusted & MOVES_NOTHING
    ) != (seen.untrusted & MOVES_NOTHING)


def _conditions(
    inputs: ControlInputs,
    sources: _Sources,
    now: float,
    config: ControlConfig,
    monitor: int,
    *,
    estop: EstopState,
) -> frozenset[Cause]:
    """Every cause whose condition holds now, whatever the mode."""
    stopping = stopping_flags(monitor, config.monitors)
    held = (
        (not is_fresh(inputs.rc, now, config.rc_timeout_s), Cause.RC_LOST),
        (
            is_fresh(inputs.rc, now, config.rc_timeout_s) and sources.rc is None,
            Cause.RC_IMPLAUSIBLE,
        ),
        (sources.can_movement is None, Cause.CAN_LOST),
        (_untrusted_moves(inputs.untrusted), Cause.CAN_UNTRUSTED),
        (sources.control is not None and sources.control.remote_stop, Cause.REMOTE_STOP),
        (inputs.dac_failing, Cause.DAC_FAULT),
        (inputs.watchdog_tripped, Cause.WATCHDOG),
        (inputs.timing_fault, Cause.TIMING),
        (estop.holds(now), Cause.ESTOP),
        *((bool(stopping & int(flag)), cause) for flag, cause in MONITOR_CAUSES),
    )
    return frozenset(cause for holds, cause in held if holds)


def _supervisor_inputs(
    state: ControlState, inputs: ControlInputs, sources: _Sources, conditions: frozenset[Cause]
) -> SupervisorInputs:
    rc, can = sources.rc, sources.can_movement
    new_control = inputs.control_frames != state.control_frames_seen and sources.control is not None
    return SupervisorInputs(
        conditions=conditions,
        switch=None if rc is None else rc.mode,
        rc_frame=inputs.rc_frames != state.rc_frames_seen,
        rc_throttle_zero=rc is not None and rc.throttle_norm == 0.0,
        can_throttle_zero=can is not None and can.throttle_norm == 0.0,
        remote_stop_rising=inputs.stop_requests != state.stop_requests_seen,
        re_enable_edge=new_control and inputs.control_edges.re_enable,
        switch_between=rc is not None and rc.mode_between,
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


def _input_flags(
    inputs: ControlInputs,
    sources: _Sources,
    supervisor: SupervisorState,
    now: float,
    config: ControlConfig,
) -> ErrorFlag:
    """Flags of the inputs as they are now, beside the latched causes' own flags."""
    flags = supervisor.flags
    if not is_fresh(inputs.rc, now, config.rc_timeout_s):
        flags |= ErrorFlag.RC_TIMEOUT
    elif sources.rc is None:
        flags |= ErrorFlag.RC_FAILSAFE
    if supervisor.switch is ControlMode.CAN and sources.can_movement is None:
        flags |= ErrorFlag.CAN_COMMAND_TIMEOUT
    if sources.control is not None and sources.control.remote_stop:
        flags |= ErrorFlag.REMOTE_STOP
    for kind in inputs.untrusted:
        flags |= command_row(kind).untrusted_flag
    return flags


def _light_request(
    mode: ControlMode, sources: _Sources, movement: Movement, flags: int
) -> LightRequest:
    rc_lights = sources.rc if mode is ControlMode.RC else None
    can_lights = sources.lights if mode is ControlMode.CAN else None
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


def _requested(supervisor: SupervisorState, sources: _Sources, speed_faulted: bool) -> Movement:
    """The commanding source's set-point; its throttle stays zero until the supervisor opens it,
    and in CAN mode while the wheel sensor is faulted (`interlocks.can_throttle_allowed`)."""
    movement = movement_from(supervisor.mode, sources.rc, sources.can_movement)
    if supervisor.throttle_allowed and can_throttle_allowed(supervisor.mode, speed_faulted):
        return movement
    return Movement(movement.steering_norm, 0.0, movement.brake_norm, movement.gear)


def controller_step(
    state: ControlState, inputs: ControlInputs, now: float, config: ControlConfig
) -> tuple[ControlState, ControlOutputs]:
    """One decision: monitors, supervisor, interlocks, then every actuator level."""
    monitor, monitor_flags = _monitor(state, inputs, now, config)
    speed_check = speed_check_step(
        state.speed_check, inputs.speed_mps, state.applied_throttle_norm, now, config.interlocks
    )
    sources = _sources(inputs, now, config)
    estop = estop_step(state.estop, inputs.estop_line_high, now)
    conditions = _conditions(inputs, sources, now, config, monitor_flags, estop=estop)
    supervisor = supervisor_step(
        state.supervisor,
        _supervisor_inputs(state, inputs, sources, conditions),
        config.supervisor,
    )
    driving = supervisor.mode is not ControlMode.STOP
    if driving and state.supervisor.mode is ControlMode.STOP:
        speed_check = cleared(speed_check)  # an arming event acknowledges a sensor fault
    speed_mps = trusted_speed(speed_check, inputs.speed_mps)
    interlock, asked, held = interlock_step(
        state.interlock,
        _requested(supervisor, sources, speed_check.faulted),
        speed_mps,
        now,
        config.interlocks,
    )
    governor = governor_step(
        state.governor,
        speed_mps,
        driving,
        now,
        config.governor,
        asked_throttle_norm=asked.throttle_norm,
    )
    movement = governed(asked, governor)
    stop, stop_phase = stop_step(
        state.stop,
        stopping=not driving,
        category=stop_category(supervisor.latched),
        powered=state.drive_applied.enable,
        speed_mps=speed_mps,
        now=now,
        config=config.stop,
        standstill_proven_s=standstill_proven_since(
            speed_check.standstill_since, speed_check.standstill_abrupt, config.stop
        ),
    )
    # In STOP the steering holds where it is: centring at speed would be a swerve.
    target_norm = movement.steering_norm if driving else state.steering.setpoint_norm
    # A source takes over (a handover, or an arming): the steering moves to it bumplessly.
    taking_over = driving and supervisor.mode is not state.supervisor.mode
    steering, pulse_s = steering_step(
        state.steering,
        target_norm,
        now,
        config.steering,
        inputs.steering_measured_norm,
        handover_speed_mps=speed_mps,
        handover=taking_over,
    )
    # Combined as plain ints: every operator on an IntFlag builds a new enum value, which costs
    # more than the rest of this line; the bits are the same.
    flags = (
        inputs.fault_flags
        | int(monitor_flags)
        | int(_input_flags(inputs, sources, supervisor, now, config))
    )
    if speed_check.faulted:
        flags |= int(ErrorFlag.SPEED_SENSOR_FAULT)
    if stop.escalated:
        flags |= int(ErrorFlag.STOP_ESCALATED)
    light_request = _light_request(supervisor.mode, sources, movement, flags)
    duty = hydrobrake_duty(movement.brake_norm, config.hydrobrake_threshold_norm)
    if stop_phase is StopPhase.BRAKING:  # category 1: the drive brakes, powered, at 0 V
        drive = braking_drive(state.drive_applied, config.drive)
    else:
        drive = drive_outputs(movement, enabled=driving, config=config.drive)
    outputs = ControlOutputs(
        mode=supervisor.mode,
        causes=supervisor.latched,
        movement=movement,
        direction_change_held=held,
        steering_pulse_s=pulse_s,
        steering_hold_pulse_s=pulse_for_steering(steering.setpoint_norm, config.steering),
        stop_phase=stop_phase,
        drive=drive,
        hydrobrake_duty=duty,
        ebrake_engaged=not driving,
        lights=light_outputs(light_request, now, config.blink_rate_hz),
        light_request=light_request,
        error_flags=int(flags),
        requests=_requests(supervisor.mode, sources) if REQUESTS else (),
        speed_limited=acting(asked, governor),
    )
    new_state = ControlState(
        supervisor,
        steering,
        interlock,
        monitor,
        speed_check,
        duty,
        movement.throttle_norm if drive.enable else 0.0,
        inputs.rc_frames,
        inputs.control_frames,
        inputs.stop_requests,
        stop,
        drive,
        estop,
        governor,
    )
    return new_state, outputs


class Arrivals(Protocol):
    """The newest stamped input of each kind, as the shell holds them between decisions."""

    @property
    def rc(self) -> Stamped[RcRequest | None] | None: ...
    @property
    def commands(self) -> CommandSlots: ...
    @property
    def control_edges(self) -> CommandEdges: ...
    @property
    def rc_frames(self) -> int: ...
    @property
    def stop_requests(self) -> int: ...


T = TypeVar("T")
C = TypeVar("C", bound=Command)


def changes_decision(
    state: ControlState,
    seen: ControlInputs,
    decided_at: float,
    arrivals: Arrivals,
    config: ControlConfig,
) -> bool:
    """Whether inputs that arrived after the decision taken at `decided_at` on `seen` (which left
    `state`) can change it before the next periodic one: False when each of them repeats what the
    decision saw, fresh, and the switch's debounce is not counting frames.

    A repeated frame then only renews its input's age, which no rule acts on before it expires;
    everything that moves with time alone (timeouts, dwells, monitors, blinking) is judged at the
    next periodic decision, as it is when no frame arrives at all, within the deadline every fault
    has (its threshold plus one control period). So the shell decides at once on every frame that
    asks for something new, and not on the hundreds a second that only repeat a request.
    """
    if arrivals.rc_frames != seen.rc_frames and counting(state.supervisor, config.supervisor):
        return True
    if arrivals.stop_requests != seen.stop_requests:
        return True
    if arrivals.commands is not seen.commands:
        for spec in COMMANDS:
            kind = spec.kind
            newest, before = arrivals.commands.get(kind), seen.commands.get(kind)
            if newest is before:  # this slot is as the decision saw it (most are, every time)
                continue
            timeout_s = config.command_timeout_s(kind)
            if not _repeats(newest, before, decided_at, timeout_s, same_request):
                return True
    return not (
        _repeats(arrivals.rc, seen.rc, decided_at, config.rc_timeout_s, operator.eq)
        # operator.eq, not ==: compiled, mypyc makes == between two instances of a class it
        # sees no __eq__ in (an @value class: the decorator adds it) an identity test (issue 43)
        and operator.eq(arrivals.control_edges, seen.control_edges)
    )


def _repeats(
    newest: Stamped[T] | None,
    seen: Stamped[T] | None,
    decided_at: float,
    timeout_s: float,
    same: Callable[[T, T], bool],
) -> bool:
    """Nothing new for this input, or a frame that asks what the decision saw it ask, fresh."""
    if newest is seen:
        return True
    return (
        newest is not None
        and seen is not None
        and is_fresh(seen, decided_at, timeout_s)
        and same(newest.value, seen.value)
    )
