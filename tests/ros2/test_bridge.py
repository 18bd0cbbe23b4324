"""The bridge's rules over random sequences of periods: re-enable only on request, a remote stop
in every period it is asked for, no throttle unless engaged with a usable set-point."""

from __future__ import annotations

from dataclasses import dataclass

from hypothesis import given
from hypothesis import strategies as st

from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode, ErrorReport, Gear, ModeReport, WheelSpeedReport
from bywire.ros2.bridge import Activity, BridgeState, Inputs, Requests, bridge_step
from bywire.ros2.setpoint import Setpoint, usable
from bywire.ros2.settings import BridgeSettings
from bywire.teleop.reports import ReportView

SETTINGS = BridgeSettings()
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
            WheelSpeedReport: (now_s, WheelSpeedReport(speed, speed)),
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


periods = st.builds(
    Period,
    mode=st.sampled_from(ControlMode),
    latched=st.booleans(),
    speed=st.floats(-1.0, 2.0),
    setpoint_age=st.none() | st.floats(0.0, 0.5),
    enable=st.booleans(),
    remote_stop=st.booleans(),
    reports_lost=st.booleans(),
)


@given(st.lists(periods, min_size=1, max_size=80))
def test_rules_hold_over_any_sequence(sequence: list[Period]) -> None:
    state, calls = BridgeState(), 0
    for index, period in enumerate(sequence):
        now_s = 1.0 + index * PERIOD_S
        reports_s = now_s - 1.0 if period.reports_lost else now_s
        robot = view(reports_s, period.mode, period.latched, period.speed)
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
        if not state.engaged:
            assert decision.activity is Activity.DISENGAGED
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
