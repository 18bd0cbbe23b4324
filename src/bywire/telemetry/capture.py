"""The loop's side of the telemetry feed: cheap, frozen captures of the controller, queued.

`TelemetryTap` is a `Runtime.on_cycle` observer. Every pass it compares the decision with the one
before (by identity first: most passes take none) to queue events as they happen; at the feed's
rate it queues one `StateCapture`. A capture only holds references to frozen values the loop made
anyway (the decision, its inputs, the sensor readings) and copies a few counters, so the loop
pays for a handful of attribute reads and one append; turning captures into messages happens in
the writer's thread. `can_frame` queues a CAN frame the same way.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from bywire.control.controller import ControlInputs, ControlOutputs
from bywire.control.error_flags import flag_names
from bywire.runtime.app import Runtime
from bywire.runtime.schedule import TaskSpec
from bywire.runtime.sensors import SensorReadings
from bywire.telemetry.outbox import Outbox

DEFAULT_RATE_HZ = 50.0


class TaskCounters(NamedTuple):
    """One schedule row's counters at the capture (the loop keeps mutating the originals)."""

    runs: int
    overruns: int
    budget_exceeded: int
    max_jitter_s: float
    spent_s: float


class StateCapture(NamedTuple):
    """The controller at `time_s` (its clock): every value is frozen or a copy.

    A named tuple, not a dataclass: it is built in the loop 50 times a second, and a tuple is
    built in a fraction of a frozen dataclass's time (no `object.__setattr__` per field).
    """

    time_s: float
    elapsed_s: float
    outputs: ControlOutputs
    inputs: ControlInputs
    sensors: SensorReadings
    dac_throttle_volts: float | None  # acknowledged by the DAC, after quantisation
    dac_regen_volts: float | None
    task_specs: tuple[TaskSpec, ...]  # the schedule table (the same tuple every time)
    tasks: tuple[TaskCounters, ...]  # in the table's order
    watchdog_tripped: bool
    reports_sent: int
    telemetry_dropped: int


@dataclass(frozen=True, slots=True)
class EventCapture:
    """Something that happened at `time_s`: a mode change, a latch or clear, a flag."""

    time_s: float
    kind: str  # "mode", "latched", "cleared", "flag_raised", "flag_cleared"
    name: str  # the new mode, the cause or the flag
    mode: str  # the mode after the event


@dataclass(frozen=True, slots=True)
class CanCapture:
    """One CAN frame as it crossed the bus (`sender`: the node, when the bus knows it)."""

    time_s: float
    arbitration_id: int
    data: bytes
    sender: str


Capture = StateCapture | EventCapture | CanCapture


class TelemetryTap:
    """Observes the runtime's loop and queues captures into `outbox`; never blocks the loop."""

    def __init__(
        self, runtime: Runtime, outbox: Outbox[Capture], *, rate_hz: float = DEFAULT_RATE_HZ
    ) -> None:
        if not rate_hz > 0:
            raise ValueError(f"telemetry rate must be positive, got {rate_hz} Hz")
        self._runtime = runtime
        self._outbox = outbox
        self._rate_hz = rate_hz
        self._first_s = runtime.started_at
        self._ticks = 0
        self._next_s = self._first_s
        self._last: ControlOutputs | None = None
        channels = runtime.config.actuators
        self._dac_channels = (channels.dac_throttle_channel, channels.dac_regen_channel)
        self._task_specs = tuple(task.spec for task in runtime.tasks)
        self._task_stats = tuple(task.stats for task in runtime.tasks)

    def attach(self) -> TelemetryTap:
        """Observe the runtime's loop from its next pass on."""
        self._runtime.on_cycle.append(self.observe)
        return self

    def detach(self) -> None:
        """Stop observing (the feed is closing)."""
        if self.observe in self._runtime.on_cycle:
            self._runtime.on_cycle.remove(self.observe)

    def observe(self, now: float) -> None:
        """From the loop, after a pass: queue events now, and the state when it is due."""
        outputs = self._runtime.outputs
        if outputs is None:
            return
        if outputs is not self._last:
            self._events(self._last, outputs, now)
            self._last = outputs
        if now >= self._next_s:
            self._outbox.put(self._capture(outputs, now))
            self._advance(now)

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
        return StateCapture(
            now,
            now - runtime.started_at,
            outputs,
            runtime.inputs,
            runtime.sensors,
            acknowledged_volts(throttle_channel),
            acknowledged_volts(regen_channel),
            self._task_specs,
            tuple(
                TaskCounters(s.runs, s.overruns, s.budget_exceeded, s.max_jitter_s, s.spent_s)
                for s in self._task_stats
            ),
            watchdog is not None and watchdog.tripped,
            runtime.reports_sent,
            self._outbox.dropped,
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
