"""The bridge's shell on the CAN side: owns the bus, and every 20 ms reads the robot's reports,
takes the bridge's decision and sends the three commands (counter, CRC and, with a signer, each
frame's SecOC authenticator), on a thread of its own with absolute deadlines.

It needs no ROS: the rclpy node (`bywire.ros2.node`) only offers set-points and requests through
the thread-safe methods and reads `snapshot()`, through `link_process.LinkProcess`, which runs
this link in a process of its own. So a stalled ROS executor changes nothing here:
the set-point simply ages out and the stop ramp brings the robot to standstill, with the commands
still going out. A test drives `tick()` from a simulated clock instead of `run()`.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import can

from bywire.errors import HardwareError
from bywire.model import StatusReport, SteeringReport, WheelSpeedReport
from bywire.protocol import dbc
from bywire.ros2 import odometry
from bywire.ros2.bridge import BridgeState, Decision, Inputs, Requests, bridge_step
from bywire.ros2.diagnostics import LinkHealth, with_tally
from bywire.ros2.enabling import Answer
from bywire.ros2.odometry import Pose
from bywire.ros2.robot import RobotStatus, robot_status
from bywire.ros2.setpoint import Refusal, Setpoint, Tally, arrived, held
from bywire.ros2.settings import BridgeSettings, Geometry
from bywire.runtime.realtime import SCHED_FIX
from bywire.security.session import TRIP_IDS, SecocSigner
from bywire.teleop.frames import SEND_PERIOD_S, Counters, frames
from bywire.teleop.reports import ReportView, fold
from bywire.teleop.state import TeleopState


@dataclass(frozen=True, slots=True)
class Snapshot:
    """What the node publishes, taken after each period."""

    status: RobotStatus
    decision: Decision | None
    pose: Pose
    health: LinkHealth
    engaged: bool
    remote_stop: bool
    robot_status_report: StatusReport | None = None
    at_s: float = 0.0


NOTHING_YET = Snapshot(
    RobotStatus(reporting=False, report_age_s=None), None, Pose(), LinkHealth(), False, False
)
"""The snapshot before the first period."""


class LinkHandle(Protocol):
    """What the rclpy node needs of the link: `CanLink` itself, or `LinkProcess` (the same
    link in a process of its own)."""

    settings: BridgeSettings
    geometry: Geometry

    def now(self) -> float: ...
    def offer(self, setpoint: Setpoint) -> Refusal | None: ...
    def request_enable(self) -> int: ...
    def answer(self, request: int, timeout_s: float) -> Answer | None: ...
    def set_remote_stop(self, requested: bool) -> None: ...
    def snapshot(self) -> Snapshot: ...


@dataclass(slots=True)
class _Inbox:
    setpoint: Setpoint | None = None
    enable_calls: int = 0
    remote_stop: bool = False
    tally: Tally = field(default_factory=Tally)
    answers: dict[int, Answer] = field(default_factory=dict)


def command_state(decision: Decision) -> TeleopState:
    """The decision as the teleop's state, whose frames the teleop already knows how to build
    (lights off: the bridge asks for none)."""
    pedals = decision.pedals
    return TeleopState(
        steering_norm=decision.steering_norm,
        throttle_norm=pedals.throttle_norm,
        brake_norm=pedals.brake_norm,
        gear=pedals.gear,
        remote_stop=decision.remote_stop,
        re_enable_pulse=2 if decision.re_enable else 0,
    )


class CanLink:
    """The bridge on `bus`; `now` is the monotonic clock set-points' arrival times are read on."""

    def __init__(
        self,
        bus: can.BusABC,
        settings: BridgeSettings,
        geometry: Geometry,
        *,
        signer: SecocSigner | None = None,
        now: Callable[[], float] = time.monotonic,
        notifier: bool = True,
        fifo_priority: int | None = None,
    ) -> None:
        self.bus = bus
        self.settings = settings
        self.geometry = geometry
        self.now = now
        self._signer = signer
        self._state = BridgeState()
        self._counters = Counters()
        self._view = ReportView()
        self._pose = Pose()
        self._health = LinkHealth()
        self._inbox = _Inbox()
        self._lock = threading.Lock()
        self._answered = threading.Condition(self._lock)
        self._snapshot = Snapshot(
            RobotStatus(False, None), None, Pose(), LinkHealth(), False, False
        )
        self._reader: can.BufferedReader | None = can.BufferedReader() if notifier else None
        self._notifier: can.Notifier | None = None
        self.fifo_priority = fifo_priority
        self.failure: BaseException | None = None
        """Why `run` ended other than by its stop event (None while it runs or ran to a stop)."""

    # --- the node's side (any thread) ---------------------------------------------------------

    def offer(self, setpoint: Setpoint) -> Refusal | None:
        """A set-point that just arrived: stored if it passes the age gate, else counted (and
        the fate of the one it replaces with it: `setpoint.arrived`)."""
        with self._lock:
            inbox = self._inbox
            inbox.tally, refusal = arrived(inbox.tally, inbox.setpoint, setpoint, self.settings)
            if refusal is None:
                inbox.setpoint = setpoint
        return refusal

    def request_enable(self) -> int:
        """Ask for the re-enable edge; the number to wait for with `answer`."""
        with self._lock:
            self._inbox.enable_calls += 1
            return self._inbox.enable_calls

    def answer(self, request: int, timeout_s: float) -> Answer | None:
        """The answer to request `request` (or a later one, which covers it); None on timeout."""
        deadline = time.monotonic() + timeout_s
        with self._answered:
            while True:
                done = [number for number in self._inbox.answers if number >= request]
                if done:
                    return self._inbox.answers[min(done)]
                left = deadline - time.monotonic()
                if left <= 0 or not self._answered.wait(left):
                    return None

    def set_remote_stop(self, requested: bool) -> None:
        with self._lock:
            self._inbox.remote_stop = requested

    def snapshot(self) -> Snapshot:
        with self._lock:
            return self._snapshot

    # --- the CAN side (one thread) ------------------------------------------------------------

    def start(self) -> None:
        """Start receiving on a notifier thread (unless built with `notifier=False`)."""
        if self._reader is not None:
            self._notifier = can.Notifier(self.bus, [self._reader], timeout=0.05)

    def run(
        self, stop: threading.Event, after_tick: Callable[[Decision], None] | None = None
    ) -> None:
        """Tick every period on absolute deadlines until `stop` is set (calling `after_tick`
        with each decision); then one period of full brake goes out, and nothing more: the
        controller's own CAN timeout takes over."""
        try:
            self._prioritise()
            self.start()
            deadline = time.monotonic()
            while not stop.is_set():
                decision = self.tick()
                if after_tick is not None:
                    after_tick(decision)
                deadline += SEND_PERIOD_S
                late = time.monotonic() - deadline
                if late > SEND_PERIOD_S:  # far behind (suspended): start again from now
                    deadline = time.monotonic()
                stop.wait(max(0.0, deadline - time.monotonic()))
        except HardwareError as error:  # a refusal a user can act on: said in one line
            self.failure = error
        except Exception as error:
            self.failure = error  # the node reads it and ends: nothing is sent any more
            raise
        finally:
            self.close()

    def _prioritise(self) -> None:
        """With `fifo_priority`: this thread (only) at SCHED_FIFO, so that a busy planner on the
        same computer cannot starve the link past the robot's CAN timeout."""
        if self.fifo_priority is None:
            return
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(self.fifo_priority))
        except OSError as error:
            fix = SCHED_FIX.format(python=sys.executable, priority=self.fifo_priority)
            raise HardwareError(
                f"cannot run the CAN link at SCHED_FIFO {self.fifo_priority}"
                f" ({error.strerror or error}): {fix}, or leave out --link-priority"
            ) from None

    def close(self) -> None:
        """Send one period of throttle 0 and full brake, stop receiving."""
        decision = self._snapshot.decision
        if decision is not None:
            pedals = replace(decision.pedals, throttle_norm=0.0, brake_norm=1.0)
            with contextlib.suppress(Exception):  # on the way out, whatever the bus does
                self._send(command_state(replace(decision, pedals=pedals, re_enable=False)))
        if self._notifier is not None:
            self._notifier.stop()

    def tick(self) -> Decision:
        """One period: take in the reports, decide, send, publish the snapshot."""
        now_s = self.now()
        if (
            self._state.last_s is not None
            and now_s - self._state.last_s > self._health.max_period_s
        ):
            self._health = replace(self._health, max_period_s=now_s - self._state.last_s)
        self._receive(now_s)
        with self._lock:
            inbox = self._inbox
            requests = Requests(inbox.enable_calls, inbox.remote_stop)
            setpoint = inbox.setpoint
            inbox.tally = held(inbox.tally, setpoint, now_s, self.settings)
        self._state, decision = bridge_step(
            self._state, Inputs(now_s, setpoint, self._view, requests), self.settings
        )
        self._send(command_state(decision))
        self._publish(now_s, decision, setpoint)
        return decision

    def _receive(self, now_s: float) -> None:
        while (message := self._next_message()) is not None:
            if message.is_error_frame or message.is_extended_id:
                continue
            if self._signer is not None and message.arbitration_id in TRIP_IDS:
                with contextlib.suppress(OSError):  # a new trip not written: not taken, retried
                    self._signer.hear(message.arbitration_id, bytes(message.data))
                continue
            self._health = replace(self._health, frames_received=self._health.frames_received + 1)
            bad_before = self._view.bad_frames
            self._view = fold(self._view, message.arbitration_id, bytes(message.data), now_s)
            if self._view.bad_frames != bad_before:
                self._health = replace(self._health, bad_frames=self._view.bad_frames)
            elif message.arbitration_id == dbc.frame_id(WheelSpeedReport):
                wheels = self._view.get(WheelSpeedReport)
                if wheels is not None:
                    steering = self._view.get(SteeringReport)
                    self._pose = odometry.advance(
                        self._pose, wheels, steering, now_s, self.geometry
                    )

    def _next_message(self) -> can.Message | None:
        if self._reader is not None:
            return self._reader.get_message(timeout=0.0)
        return self.bus.recv(timeout=0.0)

    def _send(self, state: TeleopState) -> None:
        signer = self._signer
        if signer is not None and not signer.ready:
            return  # nothing can be signed before the robot's trip counter is heard
        period_frames, self._counters = frames(state, self._counters)
        for frame_id, data in period_frames:
            authenticator = None if signer is None else signer.authenticator(frame_id, data)
            if signer is not None and authenticator is None:
                continue  # unsigned commands are never sent
            if self._send_frame(frame_id, data) and authenticator is not None:
                self._send_frame(authenticator.arbitration_id, authenticator.data)

    def _send_frame(self, frame_id: int, data: bytes) -> bool:
        message = can.Message(arbitration_id=frame_id, data=data, is_extended_id=False)
        try:
            self.bus.send(message, timeout=SEND_PERIOD_S)
        except (can.CanError, OSError):  # a closed socketcand connection is an OSError
            self._health = replace(self._health, send_errors=self._health.send_errors + 1)
            return False
        self._health = replace(self._health, frames_sent=self._health.frames_sent + 1)
        return True

    def _bus_state(self) -> str:
        try:
            return str(self.bus.state.name).lower()
        except (NotImplementedError, AttributeError, can.CanError):
            return "unknown"

    def _publish(self, now_s: float, decision: Decision, setpoint: Setpoint | None) -> None:
        ages = (None, None) if setpoint is None else setpoint.ages_s(now_s)
        with self._lock:
            inbox = self._inbox
            self._health = with_tally(
                replace(
                    self._health,
                    bus=self._bus_state(),
                    command_age_s=ages[0],
                    stamp_age_s=ages[1],
                    activity=decision.activity.value,
                ),
                inbox.tally,
                now_s,
            )
            if decision.answer is not None:
                inbox.answers[decision.answer.request] = decision.answer
                self._answered.notify_all()
            self._snapshot = Snapshot(
                robot_status(self._view, now_s, self.settings.report_timeout_s),
                decision,
                self._pose,
                self._health,
                self._state.engaged,
                inbox.remote_stop,
                self._view.get(StatusReport),
                now_s,
            )
