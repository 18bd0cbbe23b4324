"""Every action a campaign step may name, in one table: its name, the values it may take, and
the scenario events it becomes (`Action.write`).

Each step waits its delay, then does one thing an operator, the higher-level computer or the
world can do: move a stick or a switch (or arm deliberately), bounce the switch, lose, garble or
fake the RC link, send, corrupt or stop CAN commands, pull the CAN cable or flood the bus, ask
for a remote stop or a re-enable, let a second node send on the computer's id, make DAC writes
fail or hang, kill the wheel-speed sensor, break a brake or the steering, tip the road. With the
ROS 2 bridge as the computer (a bridge campaign): what its planner publishes (speed, curvature,
rate, how old its stamps are, silence) and its service calls (`BRIDGE_ACTIONS`). A new action
is a row here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from bywire.config import RobotConfig
from bywire.model import ControlMode, Gear
from bywire.sim.scenario import Event, Scenario
from bywire.sim.verify.step_events import Step, StepEvents

RC, CAN, STOP = ControlMode.RC, ControlMode.CAN, ControlMode.STOP
ARM_HOLD_S = 0.060  # how long `arm` holds the switch at STOP: eight frames
HANDOVER_LEAD_S = 0.045  # the computer's new set-point is on the bus before the switch moves
RE_ENABLE_RISE_S = 0.045  # a re-enable: 0 in the frames now, 1 two command periods later
STALL_OF_WATCHDOG = {"short": 0.25, "long": 1.5}  # a stall inside a DAC write, in watchdogs
TAIL_S = 0.5

Write = Callable[[StepEvents, float, Any], None]


@dataclass(frozen=True, slots=True)
class Action:
    """One action: its name in a step, the values it may take (a range: any whole number in
    it; listed simplest first, a value twice to draw it more often), and what it writes."""

    name: str
    values: Sequence[object]
    write: Write


# --- what the operator does -----------------------------------------------------------------------


def _switch(events: StepEvents, at_s: float, mode: ControlMode) -> None:
    events.emit(Event(at_s, "rc", {"mode": mode.name.lower()}))


def _arm(events: StepEvents, at_s: float, mode: ControlMode) -> None:
    _switch(events, at_s, STOP)
    if mode is RC:
        events.later(at_s + ARM_HOLD_S, "rc", {"throttle": 0.0, "mode": "rc"})
    else:
        events.later(at_s + ARM_HOLD_S, "hlc", {"throttle": 0.0})
        events.later(at_s + ARM_HOLD_S, "rc", {"mode": "can"})


def _flick(events: StepEvents, at_s: float, back_after_s: float) -> None:
    back = events.switch
    _switch(events, at_s, STOP)
    if back is not STOP:
        events.later(at_s + back_after_s, "rc", {"mode": back.name.lower()})


def _handover_asking(settings: Callable[[Any], dict[str, Any]]) -> Write:
    """To the other source, which asks for `settings(value)`: to RC at once; to CAN, the
    computer's set-point first."""

    def write(events: StepEvents, at_s: float, value: Any) -> None:
        if events.switch is not RC:
            events.emit(Event(at_s, "rc", {**settings(value), "mode": "rc"}))
            return
        events.emit(Event(at_s, "hlc", settings(value)))
        events.later(at_s + HANDOVER_LEAD_S, "rc", {"mode": "can"})

    return write


def _switch_between(events: StepEvents, at_s: float, raw: int) -> None:
    events.emit(Event(at_s, "rc", {"mode_raw": raw}))
    events.switch = STOP  # no position: STOP (between RC and CAN, after the debounce's frames)


def _set(kind: str, *keys: str, name: bool = False) -> Write:
    """An `rc`, `hlc` or `hlc_lights` event setting each of `keys` to the value (an enum's
    name, lower case, with `name`)."""

    def write(events: StepEvents, at_s: float, value: Any) -> None:
        setting = value.name.lower() if name else value
        events.emit(Event(at_s, kind, dict.fromkeys(keys, setting)))

    return write


def _remote_stop(events: StepEvents, at_s: float, on: bool) -> None:
    events.emit(Event(at_s, "hlc_control", {"remote_stop": on, "re_enable": False}))


def _re_enable(events: StepEvents, at_s: float, _value: None) -> None:
    request = events.remote_stop
    events.emit(Event(at_s, "hlc_control", {"remote_stop": request, "re_enable": False}))
    rise_s = at_s + RE_ENABLE_RISE_S
    events.later(rise_s, "hlc_control", {"remote_stop": request, "re_enable": True})


# --- faults ----------------------------------------------------------------------------------


def _fault(fault: str, **values: Any) -> Write:
    """The fault `fault`, the same whatever the value."""

    def write(events: StepEvents, at_s: float, _value: Any) -> None:
        events.fault(at_s, fault, **values)

    return write


def _counted(fault: str, **values: Any) -> Write:
    """The fault `fault` with the value as its `count`."""

    def write(events: StepEvents, at_s: float, count: int) -> None:
        events.fault(at_s, fault, count=count, **values)

    return write


def _either(if_true: str, if_false: str) -> Write:
    def write(events: StepEvents, at_s: float, value: bool) -> None:
        events.fault(at_s, if_true if value else if_false)

    return write


def _named(faults: Mapping[str, str]) -> Write:
    def write(events: StepEvents, at_s: float, value: str) -> None:
        events.fault(at_s, faults[value])

    return write


ESTOP_FAULTS = {
    "press": "estop_press",
    "release": "estop_release",
    "wire": "estop_wire_break",
    "mend": "estop_wire_mend",
    "chatter": "estop_chatter",
}
ESTOP_CHATTER_READS = 7  # a press that bounces over seven reads of its line


def _estop(events: StepEvents, at_s: float, value: str) -> None:
    events.fault(at_s, ESTOP_FAULTS[value], count=ESTOP_CHATTER_READS)


def _can_corrupt(events: StepEvents, at_s: float, how: str) -> None:
    events.fault(at_s, f"can_corrupt_{how}", count=3)


def _can_flood(events: StepEvents, at_s: float, load: float) -> None:
    if load:
        events.fault(at_s, "can_flood", load=load)
    else:
        events.fault(at_s, "can_flood_off")


WITHIN_BUDGET = 0.99
"""`dac_slow`'s "within": every transfer just under the robot file's own budget, slow but no
fault, which must delay no stop past its promise (issue 41: 9.9 ms transfers under a 10 ms
budget made the operator's STOP 28 ms against 17.7 ms, and nothing looked)."""
SLOWEST_DRAWN_S = 0.001  # what a scenario's `stall_s` may be at least


def _dac_slow(events: StepEvents, at_s: float, transfer: float | str) -> None:
    if transfer == "within":
        budget_s = events.robot.timeouts.dac_transfer_budget_s
        transfer_s = max(round(WITHIN_BUDGET * budget_s, 6), SLOWEST_DRAWN_S)
    else:
        transfer_s = float(transfer)
    events.fault(at_s, "dac_slow", stall_s=transfer_s)


def _line(events: StepEvents, at_s: float, name: str) -> None:
    events.fault(at_s, "line_dead", line=name)


def _stall(events: StepEvents, at_s: float, length: str) -> None:
    stall_s = round(STALL_OF_WATCHDOG[length] * events.robot.timeouts.watchdog_s, 6)
    events.fault(at_s, "dac_stall", stall_s=stall_s)


def _nothing(_events: StepEvents, _at_s: float, _value: Any) -> None:
    """The whole campaign is authenticated, or has the bridge's parameters (`compile_steps`)."""


# --- the ROS 2 bridge as the computer: its planner and its services ----------------------------


def _planner(key: str) -> Write:
    def write(events: StepEvents, at_s: float, value: Any) -> None:
        events.emit(Event(at_s, "planner", {key: value}))

    return write


def _service(key: str) -> Write:
    def write(events: StepEvents, at_s: float, value: Any) -> None:
        events.emit(Event(at_s, "bridge_service", {key: True if value is None else value}))

    return write


BRIDGE_PRESETS: dict[str, dict[str, Any]] = {
    "default": {},
    "short_ramp": {"stop_ramp_s": 0.3, "hold_brake": 0.1},  # both at the edge of their range
    "fast": {"max_speed_mps": 3.0, "stop_ramp_s": 0.3, "hold_brake": 0.1},
}
"""The bridge's parameters a bridge campaign runs with: its defaults, or legal edges."""


FRAMES = range(5, 41)
# fmt: off
ACTIONS: tuple[Action, ...] = (
    # what the operator does
    Action("arm", (RC, RC, CAN), _arm),  # to STOP, held, the source at zero, switched over
    Action("flick", (0.005, 0.02, 0.05, 0.1), _flick),  # through STOP and back after this long
    Action("handover", (0.0, 0.2, 0.6),  # to the other source, which asks for this throttle
           _handover_asking(lambda throttle: {"throttle": throttle})),
    Action("handover_steer", (-0.9, 0.9),  # to the other source, at zero throttle, this steering
           _handover_asking(lambda steering: {"steering": steering, "throttle": 0.0})),
    Action("rc_throttle", (0.0, 0.0, 0.3, 0.8, -0.6, -1.0),  # below zero: the brake
           _set("rc", "throttle")),
    Action("can_throttle", (0.0, 0.0, 0.2, 0.6), _set("hlc", "throttle")),
    # sticks, switches and set-points
    Action("switch", tuple(ControlMode), _switch),
    Action("rc_gear", tuple(Gear), _set("rc", "gear", name=True)),
    Action("rc_steer", (-0.6, 0.0, 0.5), _set("rc", "steering")),
    Action("rc_lights", (False, True), _set("rc", "low_beam", "hazard")),
    Action("can_gear", tuple(Gear), _set("hlc", "gear", name=True)),
    Action("can_steer", (-0.5, 0.0, 0.5), _set("hlc", "steering")),
    Action("can_brake", (0.0, 0.0, 0.5, 1.0), _set("hlc", "brake")),
    Action("can_lights", (False, True), _set("hlc_lights", "turn_left", "low_beam")),
    # the RC link
    Action("chatter", range(4, 41),  # of the next frames every other one reads STOP
           _counted("switch_chatter")),
    Action("switch_between", (1250, 1750),  # the mode switch left between two positions (µs)
           _switch_between),
    Action("dither", range(10, 200),  # the mode switch's pulse dithers ±4 µs for these frames
           _counted("switch_dither")),
    Action("rc_link", (False, True), _either("rc_link_restored", "rc_link_lost")),
    Action("rc_failsafe", (False, True), _either("rc_failsafe", "rc_failsafe_off")),
    Action("rc_implausible", range(1, 4), _counted("rc_implausible")),
    Action("rc_corrupt", (1, 3, 10), _counted("ibus_corrupt")),  # frames with a damaged byte
    Action("rc_garbage", (10, 40, 200), _counted("ibus_garbage")),  # random bytes on the line
    # the CAN link
    Action("can_link", (False, True),  # the computer silent, or sending again
           _either("can_resume", "can_silence")),
    Action("can_repeat", range(1, 5),  # movement frames repeating their counter
           _counted("can_corrupt_counter")),
    Action("can_corrupt", ("crc", "length", "range"),  # the next three movement frames damaged
           _can_corrupt),
    Action("can_cable", (False, True), _either("can_plug", "can_unplug")),  # pulled, plugged
    Action("can_flood", (0.0, 0.5, 1.0), _can_flood),  # other nodes' share of the bus (0: off)
    Action("remote_stop", (False, True), _remote_stop),
    Action("re_enable", (None,), _re_enable),
    # frames a second node sends on the computer's movement id…
    Action("impostor", FRAMES, _counted("can_impostor")),
    # …on its control id (an idle teleop: no stop, no enable)
    Action("impostor_control", FRAMES, _counted("can_impostor_control")),
    # …on its lights id (the hazard lights)
    Action("impostor_lights", FRAMES, _counted("can_impostor_lights")),
    # …on the movement id, signing with the computer's key
    Action("impostor_keyed", FRAMES, _counted("can_impostor", keyed=True)),
    # …answering each frame with a bad CRC and a forgery of its counter
    Action("forgery", FRAMES, _counted("can_forgery")),
    # the computer sends each movement frame twice (harmless)
    Action("doubles", FRAMES, _counted("can_doubles")),
    # the campaign runs with authenticated commands (drawn at its start)
    Action("secoc", (True,), _nothing),
    # the actuators and sensors
    Action("dac", ("fail", "alternate", "alternate", "restore"),
           _named({"fail": "dac_fail", "alternate": "dac_nak_alternate",
                   "restore": "dac_restore"})),
    Action("stall", ("short", "long"), _stall),  # a DAC write hangs ¼ or 1.5 watchdog periods
    # every DAC transfer this long, and succeeds: ordinary, just within the file's budget,
    # within the budget the old defaults allowed (10 ms, no file's now), a crawl
    Action("dac_slow", (0.002, "within", 0.0099, 0.08), _dac_slow),
    Action("line", ("turn_left_light", "brake_light", "hydrobrake"),  # an output dies: the end
           _line),
    Action("wheel_sensor", (False, True), _either("wheel_sensor_restore", "wheel_sensor_dead")),
    Action("hydrobrake", (False, True),  # builds no pressure, or works again
           _either("hydrobrake_restore", "hydrobrake_fail")),
    Action("ebrake", (False,), _fault("ebrake_fail")),  # the spring brake fails to engage
    Action("servo", (False, True), _either("servo_free", "servo_stuck")),  # stuck, or free
    Action("encoder", (False,), _fault("encoder_fail")),  # the steering encoder gives nothing
    # the E-stop: pressed, released, its wire broken or mended, a press that bounces
    Action("estop", tuple(ESTOP_FAULTS), _estop),
    # the ROS 2 bridge is the computer (drawn at a bridge campaign's start), with these parameters
    Action("bridge", tuple(BRIDGE_PRESETS), _nothing),
    # its planner: cmd_vel's speed, the curvature (1/m, left > 0), silent or publishing again,
    # each stamp this old on arrival (below zero: ahead), this many messages a second
    Action("planner_speed", (0.0, 0.5, 1.0, 2.0, 3.0, -0.5), _planner("speed_mps")),
    Action("planner_turn", (0.0, -0.5, 0.5), _planner("curvature_per_m")),
    Action("planner_link", (False, True), _planner("publishing")),
    Action("planner_lag", (0.0, 0.1, 0.17, 0.3, -0.3), _planner("stamp_lag_s")),
    Action("planner_rate", (20.0, 10.0, 50.0), _planner("rate_hz")),
    # its services: ~/enable, ~/remote_stop
    Action("bridge_enable", (None,), _service("enable")),
    Action("bridge_remote_stop", (False, True), _service("remote_stop")),
    # the road tips: its grade (rise over run forward; below zero downhill), drawn at a
    # campaign's start by `draw_bridge.draw_any`, never in the walk (the speed limit, row 67)
    Action("grade", (0.0, -0.05, -0.1), _set("world", "grade")),
)
# fmt: on
BY_NAME: dict[str, Action] = {action.name: action for action in ACTIONS}
VOCABULARY: dict[str, Sequence[object]] = {action.name: action.values for action in ACTIONS}
"""Every action a step may name, with the values it may take (a range: any whole number in it)."""
OPERATOR = frozenset({"arm", "flick", "handover", "rc_throttle", "can_throttle"})
"""What an operator does: drawn more often than any fault, so the robot is mostly driving."""
BRIDGE_ACTIONS = frozenset(
    name for name in BY_NAME if name == "bridge" or name.startswith(("planner_", "bridge_"))
)
"""The actions of a bridge campaign's computer: a campaign with any of them runs the bridge."""


def compile_steps(steps: Iterable[Step], robot: RobotConfig, name: str = "campaign") -> Scenario:
    """The scenario that does what `steps` do, ending `TAIL_S` after the last of them."""
    steps = list(steps)
    events = StepEvents(robot)
    events.start()
    at_s = 0.0
    for step in steps:
        at_s = round(at_s + step.delay_s, 6)
        events.flush(at_s)
        BY_NAME[step.action].write(events, at_s, step.value)
    events.flush(float("inf"))
    bridge = any(step.action in BRIDGE_ACTIONS for step in steps)
    presets = [step.value for step in steps if step.action == "bridge"]
    parameters = BRIDGE_PRESETS[str(presets[0])] if presets else {}
    end_s = max((event.at_s for event in events.events), default=0.0)
    end_s = max(end_s, sum(step.delay_s for step in steps))
    return Scenario(
        name=name,
        description=f"a fault campaign of {len(steps)} steps",
        duration_s=round(end_s + TAIL_S, 6),
        events=tuple(events.events),
        expectations=(),
        authenticated=any(step.action == "secoc" for step in steps),
        computer="bridge" if bridge else "hlc",
        bridge=tuple(sorted(parameters.items())),
    )
