"""The loop's side of the telemetry feed: flat captures of the controller, queued.

`TelemetryTap` is a `Runtime.on_cycle` observer. Every pass it compares the decision with the one
before (by identity first: most passes take none) to queue events as they happen; at the feed's
rate it queues one `StateCapture`. `can_frame` queues a CAN frame the same way.

A capture holds plain values only (numbers, strings, None, plain tuples of them): the loop copies
the few dozen values a state message shows (~14 µs), so that a capture can cross to the writer's
process with `marshal` (see `wire`) instead of being encoded (~80 µs for a state message) by a
thread of the controller's own process. Turning captures into messages is the writer's work
(`messages`), never the loop's.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple

from bywire.command_table import COMMANDS
from bywire.control.validity import age_s
from bywire.error_flags import flag_names
from bywire.model import MovementCommand
from bywire.telemetry.outbox import Outbox
from bywire.telemetry.schemas import LIGHTS

if TYPE_CHECKING:  # the writer's process imports this module and needs none of them
    from bywire.control.controller import ControlOutputs
    from bywire.control.mux import Movement
    from bywire.control.rc_mapping import RcRequest
    from bywire.model import MovementCommand
    from bywire.runtime.loop import Runtime

DEFAULT_RATE_HZ = 50.0

MovementValues = tuple[float, float, float, str]
"""A set-point or a request: steering, throttle and brake (normalised) and the gear's name."""

TaskRow = tuple[str, float, int, int, int, float, float]
"""One schedule row at the capture: name, nominal rate (Hz), runs, overruns, budget exceeded,
largest jitter (s), time spent (s); copies, since the loop keeps mutating its counters."""


class StateCapture(NamedTuple):
    """The controller at `time_s` (its clock), as plain values; ages are taken at `time_s`.

    A named tuple, not a dataclass: it is built in the loop 50 times a second, and a tuple is
    built in a fraction of a frozen dataclass's time (no `object.__setattr__` per field).
    """

    time_s: float
    elapsed_s: float
    mode: str
    latched_causes: tuple[str, ...]  # sorted by name
    direction_change_held: bool
    setpoint: MovementValues
    motors_enabled: bool
    forward: bool
    reverse: bool
    throttle_volts: float
    regen_volts: float
    dac_throttle_volts: float | None  # acknowledged by the DAC, after quantisation
    dac_regen_volts: float | None
    ebrake_engaged: bool
    steering_pulse_s: float
    hydrobrake_duty: float
    lights: tuple[bool, ...]  # in `LIGHTS` order
    error_flags: int
    rc_age_s: float | None
    can_ages_s: tuple[float | None, ...]  # each command row's newest frame's, in `COMMANDS` order
    rc_frames: int
    can_control_frames: int
    rc_request: MovementValues | None
    can_movement: MovementValues | None
    speed_mps: float | None
    speed_limit_mps: float | None  # `[limits] max_speed_mps` (None: no limit)
    speed_limited: bool  # the governor holds the throttle below what was asked, or brakes
    wheel_left_mps: float | None
    wheel_right_mps: float | None
    hydrobrake_pressure_bar: float | None
    steering_measured_norm: float | None
    watchdog_tripped: bool
    reports_sent: int
    telemetry_dropped: int
    tasks: tuple[TaskRow, ...]  # in the schedule table's order


class EventCapture(NamedTuple):
    """Something that happened at `time_s`: a mode change, a latch or clear, a flag."""

    time_s: float
    kind: str  # "mode", "latched", "cleared", "flag_raised", "flag_cleared"
    name: str  # the new mode, the cause or the flag
    mode: str  # the mode after the event


class CanCapture(NamedTuple):
    """One CAN frame as it crossed the bus (`sender`: the node, when the bus knows it)."""

    time_s: float
    arbitration_id: int
    data: bytes
    sender: str


class PoseCapture(NamedTuple):
    """Where the simulated vehicle is at `time_s` (the simulator's truth, not the controller's):
    x and y in metres from where it started, heading counter-clockwise from x."""

    time_s: float
    x_m: float
    y_m: float
    heading_rad: float


Capture = StateCapture | EventCapture | CanCapture | PoseCapture


def movement_values(movement: Movement | MovementCommand | RcRequest) -> MovementValues:
    return (movement.steering_norm, movement.throttle_norm, movement.brake_norm, movement.gear.name)


class TelemetryTap:
    """Observes the runtime's loop and queues captures into `outbox`; never blocks the loop.

    `ship`: called after every pass with the loop's time, where a writer process is fed from the
    loop itself (`WriterProcess.ship`); None where a writer thread takes from the outbox.
    """

    def __init__(
        self,
        runtime: Runtime,
        outbox: Outbox[Capture],
        *,
        rate_hz: float = DEFAULT_RATE_HZ,
        ship: Callable[[float], None] | None = None,
    ) -> None:
        if not rate_hz > 0:
            raise ValueError(f"telemetry rate must be positive, got {rate_hz} Hz")
        self._runtime = runtime
        self._outbox = outbox
        self._ship = ship
        self._rate_hz = rate_hz
        self._first_s = runtime.started_at
        self._ticks = 0
        self._next_s = self._first_s
        self._last: ControlOutputs | None = None
        channels = runtime.config.actuators
        self._dac_channels = (channels.dac.throttle_channel, channels.dac.regen_channel)
        self._tasks = tuple(
            ((task.spec.name, task.spec.rate_hz), task.stats) for task in runtime.tasks
        )

    def attach(self) -> TelemetryTap:
        """Observe the runtime's loop from its next pass on."""
        self._runtime.on_cycle.append(self.observe)
        return self

    def detach(self) -> None:
        """Stop observing (the feed is closing)."""
        if self.observe in self._runtime.on_cycle:
            self._runtime.on_cycle.remove(self.observe)

    def observe(self, now: float) -> None:
        """From the loop, after a pass: queue events now, and the state when it is due; then
        `ship` what is queued, if the feed's writer is another process."""
        outputs = self._runtime.outputs
        if outputs is not None:
            if outputs is not self._last:
                self._events(self._last, outputs, now)
                self._last = outputs
            if now >= self._next_s:
                self._outbox.put(self._capture(outputs, now))
                self._advance(now)
        if self._ship is not None:
            self._ship(now)

    def can_frame(self, time_s: float, arbitration_id: int, data: bytes, sender: str = "") -> None:
        """Queue one CAN frame (a bus monitor calls this)."""
        self._outbox.put(CanCapture(time_s, arbitration_id, data, sender))

    def _advance(self, now: float) -> None:
        """Absolute deadlines, as the schedule keeps them: `first + ticks / rate`, never a sum;
        a late pass skips the deadlines it missed instead of bunching captures."""
        self._ticks += 1
        self._next_s = self._first_s + self._ticks / self._rate_hz
        if now >= self._next_s:
            self._ticks = int((now - self._first_s) * self._rate_hz) + 1
            self._next_s = self._first_s + self._ticks / self._rate_hz

    def _capture(self, outputs: ControlOutputs, now: float) -> StateCapture:
        runtime = self._runtime
        acknowledged_volts = runtime.actuators.acknowledged_volts
        throttle_channel, regen_channel = self._dac_channels
        watchdog = runtime.watchdog
        inputs, sensors = runtime.inputs, runtime.sensors
        drive, lights = outputs.drive, outputs.lights
        rc, movement = inputs.rc, inputs.commands.get(MovementCommand)
        rc_request = None if rc is None else rc.value
        wheels = sensors.wheel_speeds_mps
        return StateCapture(
            now,
            now - runtime.started_at,
            outputs.mode.name,
            tuple(sorted(cause.name for cause in outputs.causes)) if outputs.causes else (),
            outputs.direction_change_held,
            movement_values(outputs.movement),
            drive.enable,
            drive.forward,
            drive.reverse,
            drive.throttle_volts,
            drive.regen_volts,
            acknowledged_volts(throttle_channel),
            acknowledged_volts(regen_channel),
            outputs.ebrake_engaged,
            outputs.steering_pulse_s,
            outputs.hydrobrake_duty,
            tuple(getattr(lights, name) for name in LIGHTS),
            outputs.error_flags,
            age_s(rc, now),
            tuple(age_s(inputs.commands.get(spec.kind), now) for spec in COMMANDS),
            inputs.rc_frames,
            inputs.control_frames,
            None if rc_request is None else movement_values(rc_request),
            None if movement is None else movement_values(movement.value),
            sensors.speed_mps,
            runtime.config.control.governor.max_speed_mps,
            outputs.speed_limited,
            None if wheels is None else wheels[0],
            None if wheels is None else wheels[1],
            sensors.hydrobrake_pressure_bar,
            sensors.steering_measured_norm,
            watchdog is not None and watchdog.tripped,
            runtime.reports_sent,
            self._outbox.dropped,
            tuple(
                (name, rate_hz, s.runs, s.overruns, s.budget_exceeded, s.max_jitter_s, s.spent_s)
                for (name, rate_hz), s in self._tasks
            ),
        )

    def _events(self, before: ControlOutputs | None, after: ControlOutputs, now: float) -> None:
        """Queue what changed between two decisions (everything, for the first one)."""
        mode = after.mode.name
        put = self._outbox.put
        if before is None or after.mode is not before.mode:
            put(EventCapture(now, "mode", mode, mode))
        causes_before = frozenset() if before is None else before.causes
        if after.causes != causes_before:
            for cause in sorted(after.causes - causes_before, key=lambda c: c.name):
                put(EventCapture(now, "latched", cause.name, mode))
            for cause in sorted(causes_before - after.causes, key=lambda c: c.name):
                put(EventCapture(now, "cleared", cause.name, mode))
        flags_before = 0 if before is None else before.error_flags
        if after.error_flags != flags_before:
            for name in flag_names(after.error_flags & ~flags_before):
                put(EventCapture(now, "flag_raised", name, mode))
            for name in flag_names(flags_before & ~after.error_flags):
                put(EventCapture(now, "flag_cleared", name, mode))
