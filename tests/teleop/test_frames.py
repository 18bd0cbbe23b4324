"""One period of teleop traffic decodes with the controller's own checks: counters, CRC, values."""

from __future__ import annotations

import pytest

from bywire.model import ControlCommand, Gear, LightsCommand, MovementCommand
from bywire.protocol import dbc
from bywire.teleop.frames import SEND_PERIOD_S, Counters, frames
from bywire.teleop.state import RE_ENABLE_FRAMES, TeleopState, advance, press

KINDS = (ControlCommand, MovementCommand, LightsCommand)


def test_the_send_period_is_the_databases_cycle_time_of_every_command() -> None:
    for kind in KINDS:
        assert dbc.period_s(dbc.frame_id(kind)) == SEND_PERIOD_S


def test_one_period_is_control_then_movement_then_lights() -> None:
    sent, _ = frames(TeleopState(), Counters())
    assert [frame_id for frame_id, _ in sent] == [dbc.frame_id(kind) for kind in KINDS]


def test_frames_decode_with_consecutive_counters_across_the_wrap() -> None:
    counters, previous = Counters(), dict.fromkeys(KINDS)
    for period in range(40):
        sent, counters = frames(TeleopState(), counters)
        for frame_id, data in sent:
            command = dbc.decode_command(frame_id, data, previous[type_of(frame_id)])
            assert command.counter == period % 16
            previous[type(command)] = command.counter


def type_of(frame_id: int) -> type[ControlCommand | MovementCommand | LightsCommand]:
    return next(kind for kind in KINDS if dbc.frame_id(kind) == frame_id)


def test_a_repeated_period_is_rejected_by_the_counter_check() -> None:
    sent, _ = frames(TeleopState(), Counters(movement=7))
    frame_id, data = sent[1]
    with pytest.raises(dbc.CommandRejected) as rejected:
        dbc.decode_command(frame_id, data, previous_counter=7)
    assert rejected.value.reason is dbc.RejectReason.COUNTER


def decoded(state: TeleopState) -> tuple[ControlCommand, MovementCommand, LightsCommand]:
    sent, _ = frames(state, Counters(3, 4, 5))
    control, movement, lights = (dbc.decode_command(i, data, None) for i, data in sent)
    assert isinstance(control, ControlCommand)
    assert isinstance(movement, MovementCommand)
    assert isinstance(lights, LightsCommand)
    return control, movement, lights


def test_the_set_points_arrive_as_pressed() -> None:
    state = TeleopState()
    for key in ("f", "up", "up", "up", "left", "left", "z", "l"):
        state = press(state, key, 0.0)
    control, movement, lights = decoded(state)
    assert (movement.steering_norm, movement.throttle_norm) == pytest.approx((-0.2, 0.3), abs=0.01)
    assert (movement.brake_norm, movement.gear) == (0.0, Gear.FORWARD)
    assert (lights.turn_left, lights.turn_right, lights.hazard, lights.low_beam) == (
        True,
        False,
        False,
        True,
    )
    assert (control.remote_stop, control.re_enable) == (False, False)
    assert (control.counter, movement.counter, lights.counter) == (3, 4, 5)


def test_the_initial_state_sends_full_brake_in_neutral() -> None:
    _, movement, _ = decoded(TeleopState())
    assert (movement.throttle_norm, movement.brake_norm, movement.gear) == (0.0, 1.0, Gear.NEUTRAL)


def test_remote_stop_is_sent_in_every_period_until_released() -> None:
    state = press(TeleopState(), "s", 0.0)
    for period in range(5):
        assert decoded(state)[0].remote_stop
        state = advance(state, period * 0.02)
    assert not decoded(press(state, "s", 1.0))[0].remote_stop


def test_re_enable_goes_out_as_one_rising_edge() -> None:
    state = press(TeleopState(), "e", 0.0)
    sent = []
    for period in range(RE_ENABLE_FRAMES + 3):
        sent.append(decoded(state)[0].re_enable)
        state = advance(state, period * 0.02)
    assert sent == [True] * RE_ENABLE_FRAMES + [False] * 3
