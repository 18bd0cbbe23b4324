"""The bridge's rules over random sequences of periods: re-enable only on request, a remote stop
in every period it is asked for, no throttle unless engaged with a usable set-point."""

from __future__ import annotations

from dataclasses import dataclass

from hypothesis import given
from hypothesis import strategies as st

from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode, ErrorReport, Gear, ModeReport, WheelSpeedReport
from bywire.ros2 import stop_ramp
from bywire.ros2.bridge import Activity, BridgeState, Inputs, Requests, bridge_step
from bywire.ros2.setpoint import Setpoint, usable
from bywire.ros2.settings import BridgeSettings
from bywire.ros2.speed_loop import Pedals
from bywire.teleop.reports import ReportView

SETTINGS = BridgeSettings(hold_brake=0.1)
NO_FLAGS = ErrorFlag(0)
PERIOD_S = 0.02


def view(
    now_s: float, mode: ControlMode, latched: bool, speed: float, flags: ErrorFlag = NO_FLAGS
) -> ReportView:
    return ReportView(
        latest={
            ModeReport: (
                now_s,
                ModeReport(Gear.FORWARD, mode, mode is ControlMode.STOP, latched, True),
            ),
            WheelSpeedReport: (now_s, WheelSpeedReport(speed, speed, True)),
            ErrorReport: (now_s, ErrorReport(flags)),
        }
    )


@dataclass(frozen=True)
class Period:
    mode: ControlMode
    latched: bool
    speed: float
    setpoint_age: float | None
    enable: bool
    remote_stop: bool
    reports_lost: bool
    sensor_fault: bool


periods = st.builds(
    Period,
    mode=st.sampled_from(ControlMode),
    latched=st.booleans(),
    speed=st.floats(-1.0, 2.0),
    setpoint_age=st.none() | st.floats(0.0, 0.5),
    enable=st.booleans(),
    remote_stop=st.booleans(),
    reports_lost=st.booleans(),
    sensor_fault=st.booleans(),
)


@given(st.lists(periods, min_size=1, max_size=80))
def test_rules_hold_over_any_sequence(sequence: list[Period]) -> None:
    state, calls = BridgeState(), 0
    for index, period in enumerate(sequence):
        now_s = 1.0 + index * PERIOD_S
        reports_s = now_s - 1.0 if period.reports_lost else now_s
        flags = ErrorFlag.SPEED_SENSOR_FAULT if period.sensor_fault else NO_FLAGS
        robot = view(reports_s, period.mode, period.latched, period.speed, flags)
        setpoint = None
        if period.setpoint_age is not None:
            setpoint = Setpoint(0.8, 0.1, now_s - period.setpoint_age, 0.0)
        calls += period.enable
        requests = Requests(calls, period.remote_stop)
        before = state
        state, decision = bridge_step(state, Inputs(now_s, setpoint, robot, requests), SETTINGS)

        assert decision.remote_stop is period.remote_stop
        if decision.re_enable:  # only inside a pulse that a call started
            assert calls > 0
            assert state.enable_taken > 0
        if period.remote_stop:
            assert not state.engaged
        driving = state.engaged and usable(setpoint, now_s, SETTINGS)
        if decision.pedals.throttle_norm > 0.0:
            assert driving
            assert period.mode is ControlMode.CAN
            assert not period.latched
            assert not period.reports_lost
            assert not period.sensor_fault  # issue 41 finding 6: never on an untrusted speed
        blind = period.reports_lost or period.sensor_fault
        if blind and state.engaged:
            assert decision.activity is Activity.BLIND
        if blind and decision.activity is not Activity.DRIVING:
            assert decision.pedals.brake_norm in {1.0, SETTINGS.hold_brake}
        if not state.engaged:
            assert decision.activity is Activity.DISENGAGED
            assert decision.pedals.throttle_norm == 0.0
            if not blind:
                assert decision.pedals.brake_norm == SETTINGS.hold_brake
        if state.engaged and not before.engaged:
            assert decision.answer is not None
            assert decision.answer.armed


def test_without_a_call_the_re_enable_bit_never_rises() -> None:
    state = BridgeState()
    for index in range(200):
        now_s = index * PERIOD_S
        robot = view(now_s, ControlMode.STOP, True, 0.0, ErrorFlag.CAN_COMMAND_TIMEOUT)
        setpoint = Setpoint(0.5, 0.0, now_s, 0.0)
        state, decision = bridge_step(state, Inputs(now_s, setpoint, robot), SETTINGS)
        assert not decision.re_enable
        assert decision.pedals.throttle_norm == 0.0


def _run_enable(robot_mode: ControlMode, latched: bool, flags: ErrorFlag) -> list[bool]:
    """The re-enable bits of the periods after one call, and the answer's verdict last."""
    state, bits = BridgeState(), []
    for index in range(100):
        now_s = index * PERIOD_S
        robot = view(now_s, robot_mode, latched, 0.0, flags)
        inputs = Inputs(now_s, None, robot, Requests(enable=1))
        state, decision = bridge_step(state, inputs, SETTINGS)
        bits.append(decision.re_enable)
        if decision.answer is not None:
            return [*bits, decision.answer.armed]
    return bits


def test_a_call_sends_one_rising_edge_then_answers() -> None:
    outcome = _run_enable(ControlMode.CAN, False, ErrorFlag(0))
    bits, armed = outcome[:-1], outcome[-1]
    assert bits[:5] == [True] * 5
    assert not any(bits[5:])
    assert armed


def test_a_latch_only_the_transmitter_can_clear_is_named_in_the_answer() -> None:
    state = BridgeState()
    answer = None
    for index in range(100):
        now_s = index * PERIOD_S
        robot = view(now_s, ControlMode.STOP, True, 0.0, ErrorFlag.RC_TIMEOUT)
        state, decision = bridge_step(state, Inputs(now_s, None, robot, Requests(1)), SETTINGS)
        answer = decision.answer or answer
    assert answer is not None
    assert not answer.armed
    assert "RC_TIMEOUT" in answer.message
    assert "transmitter" in answer.message


def _engaged(speed_mps: float) -> tuple[BridgeState, float]:
    """A bridge enabled and driving at `speed_mps` (its state, and the time)."""
    state = BridgeState()
    now_s = 0.0
    for index in range(200):
        now_s = index * PERIOD_S
        robot = view(now_s, ControlMode.CAN, False, speed_mps)
        inputs = Inputs(now_s, Setpoint(speed_mps, 0.0, now_s, 0.0), robot, Requests(enable=1))
        state, decision = bridge_step(state, inputs, SETTINGS)
    assert decision.activity is Activity.DRIVING
    assert decision.pedals.throttle_norm > 0.0
    return state, now_s


def test_a_speed_sensor_fault_takes_the_throttle_at_once_and_brakes_fully_for_the_bound() -> None:
    """Issue 41 finding 6, the rule alone: the dead sensor reads 0, the flag is up."""
    state, now_s = _engaged(0.5)
    bound_s = stop_ramp.blind_brake_s(SETTINGS)
    brakes = []
    for index in range(1, 100):
        at_s = now_s + index * PERIOD_S
        robot = view(at_s, ControlMode.CAN, False, 0.0, ErrorFlag.SPEED_SENSOR_FAULT)
        inputs = Inputs(at_s, Setpoint(0.5, 0.0, at_s, 0.0), robot, Requests(enable=1))
        state, decision = bridge_step(state, inputs, SETTINGS)
        assert decision.pedals.throttle_norm == 0.0
        assert decision.activity is Activity.BLIND
        assert state.engaged
        brakes.append((index * PERIOD_S, decision.pedals.brake_norm))
    assert all(brake == 1.0 for since_s, brake in brakes if since_s < bound_s + PERIOD_S - 1e-9)
    assert all(brake == 0.1 for since_s, brake in brakes if since_s > bound_s + PERIOD_S)


def test_a_stale_error_report_is_an_unknown_speed() -> None:
    """The flags cannot be read: the speed is not trusted, whatever the wheel report says."""
    state, now_s = _engaged(0.5)
    at_s = now_s + PERIOD_S
    robot = view(at_s, ControlMode.CAN, False, 0.5)
    errors_s = at_s - SETTINGS.report_timeout_s - PERIOD_S
    robot.latest[ErrorReport] = (errors_s, ErrorReport(NO_FLAGS))
    inputs = Inputs(at_s, Setpoint(0.5, 0.0, at_s, 0.0), robot, Requests(enable=1))
    _, decision = bridge_step(state, inputs, SETTINGS)
    assert decision.pedals == Pedals(0.0, 1.0, Gear.FORWARD)
    assert decision.activity is Activity.BLIND


def test_an_unmeasured_wheel_speed_is_an_unknown_speed() -> None:
    """Row 60: a robot without a wheel sensor reports 0 m/s with `measured_valid` 0 and no flag;
    the bridge never takes it for standstill: no throttle, full brake, BLIND, in every period."""
    state, now_s = _engaged(0.5)
    for index in range(1, 100):
        at_s = now_s + index * PERIOD_S
        robot = view(at_s, ControlMode.CAN, False, 0.0)
        robot.latest[WheelSpeedReport] = (at_s, WheelSpeedReport(0.0, 0.0, False))
        inputs = Inputs(at_s, Setpoint(0.5, 0.0, at_s, 0.0), robot, Requests(enable=1))
        state, decision = bridge_step(state, inputs, SETTINGS)
        assert decision.pedals.throttle_norm == 0.0
        assert decision.activity is Activity.BLIND
        assert not decision.status.speed_trusted
