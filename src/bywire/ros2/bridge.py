"""The bridge's decision for one send period: set-point, robot reports and requests in, the three
commands and the service answers out. Pure: the caller gives the monotonic time `now_s`.

The rules, in the order they are applied:

1. A remote stop request is sent in every period while it is on, and disengages the bridge.
2. The bridge drives only while *engaged*: set by a successful `~/enable` (`enabling`), cleared
   the period the robot is no longer drivable (left CAN mode, latched STOP, or its reports
   stopped) or a remote stop is requested. Disengaged: throttle 0, the holding brake (after
   full brake for `blind_brake_s` when the speed is not trusted: rule 4a).
3. Engaged, with a usable set-point (`setpoint.usable`: both ages within their limits) and a
   trusted speed (`RobotStatus.speed_trusted`): the speed loop drives towards its speed, the
   steering follows it.
4. Engaged, without one (the planner is silent, or its last command has aged out): throttle 0 at
   once, and the stop ramp brakes until standstill is shown (`stop_ramp`: within
   `stop_bound_s`). The commands keep going out every period, so the controller's CAN timeout is
   not what stops the robot.
4a. Engaged, without a trusted speed (SPEED_SENSOR_FAULT in the ErrorReport, or the reports
   stale): the throttle asked for is 0 from the first such period (a speed loop fed a dead
   sensor's 0 m/s would open the throttle), and the stop ramp brakes fully for `blind_brake_s`.
   Not engaged without a trusted speed (the reports stopped): the same brake, throttle 0.
5. A new direction is driven only once the robot reports it applied: its interlock holds a
   reversal back until the requested throttle has been zero at standstill for its dwell, so
   until then the bridge asks for no throttle and holds the brake (and its loop learns nothing).

The steering holds its last value whenever no set-point gives one: turning the wheels straight
while stopping is a manoeuvre nobody asked for.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from bywire.model import Gear, ModeReport
from bywire.ros2 import enabling
from bywire.ros2.enabling import Answer, Enabling
from bywire.ros2.robot import RobotStatus, robot_status
from bywire.ros2.setpoint import Setpoint, usable
from bywire.ros2.settings import BridgeSettings
from bywire.ros2.speed_loop import LoopState, Pedals, hold, speed_step
from bywire.ros2.stop_ramp import StopRamp
from bywire.teleop.frames import SEND_PERIOD_S
from bywire.teleop.reports import ReportView


class Activity(enum.Enum):
    """What the bridge does with the robot this period."""

    DISENGAGED = "not enabled: brake held, waiting for ~/enable"
    DRIVING = "driving: following the planner"
    STOPPING = "stopping: the planner is silent or stale"
    BLIND = "stopping: the robot's speed is unknown (SPEED_SENSOR_FAULT or stale reports)"


@dataclass(frozen=True, slots=True)
class Requests:
    """The services' requests: how many `~/enable` calls there have been (a number above the
    last one taken starts a new attempt, which answers every call up to it) and whether a remote
    stop is asked for."""

    enable: int = 0
    remote_stop: bool = False


@dataclass(frozen=True, slots=True)
class Inputs:
    """One period's inputs: the monotonic time, the newest admitted set-point (None before the
    first), the robot's reports with their arrival times, and the services' requests."""

    now_s: float
    setpoint: Setpoint | None
    view: ReportView
    requests: Requests = field(default_factory=Requests)


@dataclass(frozen=True, slots=True)
class BridgeState:
    loop: LoopState = field(default_factory=LoopState)
    steering_norm: float = 0.0
    ramp: StopRamp | None = None
    engaged: bool = False
    enabling: Enabling = enabling.IDLE
    enable_taken: int = 0
    last_s: float | None = None


@dataclass(frozen=True, slots=True)
class Decision:
    """This period's commands, what the bridge is doing, and a service answer if one is due."""

    steering_norm: float
    pedals: Pedals
    remote_stop: bool
    re_enable: bool
    activity: Activity
    status: RobotStatus
    answer: Answer | None = None


def _braked(
    ramp: StopRamp | None, now_s: float, speed_mps: float | None, settings: BridgeSettings
) -> tuple[StopRamp, float]:
    """The stop ramp (started now if none runs) after this period's speed (a magnitude, None
    when not trusted), and its brake."""
    ramp = (ramp or StopRamp(now_s, speed_mps)).seen(now_s, speed_mps)
    return ramp, ramp.brake_norm(now_s, speed_mps, settings)


def _movement(
    state: BridgeState,
    inputs: Inputs,
    status: RobotStatus,
    *,
    engaged: bool,
    dt_s: float,
    settings: BridgeSettings,
) -> tuple[LoopState, StopRamp | None, float, Pedals, Activity]:
    """Rules 2 to 5: the loop, the ramp, the steering, the pedals and what the bridge does."""
    now_s, setpoint = inputs.now_s, inputs.setpoint
    loop, ramp, steering = state.loop, state.ramp, state.steering_norm
    speed = status.trusted_speed_mps
    if not engaged:
        loop, activity = loop.reset(status.speed_mps), Activity.DISENGAGED
        if speed is None:  # rule 4a: the robot may roll unseen
            ramp, brake = _braked(ramp, now_s, None, settings)
            pedals = Pedals(0.0, brake, loop.gear)
        else:
            ramp, pedals = None, hold(loop, settings)
    elif speed is not None and setpoint is not None and usable(setpoint, now_s, settings):
        ramp, activity = None, Activity.DRIVING
        if setpoint.steering_norm is not None:
            steering = setpoint.steering_norm
        loop, pedals = speed_step(loop, setpoint.speed_mps, status.speed_mps, dt_s, settings)
        if pedals.gear is not status.gear and pedals.gear is not Gear.NEUTRAL:
            loop, pedals = loop.reset(0.0), hold(loop, settings)  # see rule 5
    else:
        activity = Activity.STOPPING if speed is not None else Activity.BLIND
        ramp, brake = _braked(ramp, now_s, None if speed is None else abs(speed), settings)
        loop = loop.reset(status.speed_mps)
        pedals = Pedals(0.0, brake, loop.gear)
    return loop, ramp, steering, pedals, activity


def bridge_step(
    state: BridgeState, inputs: Inputs, settings: BridgeSettings
) -> tuple[BridgeState, Decision]:
    """The next state and this period's decision."""
    now_s, view, requests = inputs.now_s, inputs.view, inputs.requests
    status = robot_status(view, now_s, settings.report_timeout_s)
    dt_s = SEND_PERIOD_S if state.last_s is None else min(max(now_s - state.last_s, 0.0), 0.1)
    engaged = state.engaged and status.drivable and not requests.remote_stop
    progress, answer, taken = state.enabling, None, state.enable_taken
    if requests.remote_stop and progress.phase is not enabling.Phase.IDLE:
        message = "remote stop requested while enabling"
        progress, answer = enabling.IDLE, Answer(progress.request, False, message)
    elif requests.enable > taken and progress.phase is enabling.Phase.IDLE:
        taken = requests.enable
        if engaged:
            answer = Answer(taken, True, "already enabled: the robot is in CAN mode")
        else:
            progress, answer = enabling.start(taken, now_s, requests.remote_stop)
    re_enable = progress.re_enable
    if progress.phase is not enabling.Phase.IDLE:
        mode_seen = view.latest.get(ModeReport)
        arrived_s = None if mode_seen is None else mode_seen[0]
        progress, done = enabling.advance(
            progress, status, arrived_s, now_s, settings.enable_timeout_s
        )
        if done is not None:
            answer, engaged = done, done.armed
    loop, ramp, steering, pedals, activity = _movement(
        state, inputs, status, engaged=engaged, dt_s=dt_s, settings=settings
    )
    next_state = BridgeState(loop, steering, ramp, engaged, progress, taken, now_s)
    decision = Decision(steering, pedals, requests.remote_stop, re_enable, activity, status, answer)
    return next_state, decision
