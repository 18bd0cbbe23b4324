"""The bridge drives the whole simulated robot (real controller, real frames) on virtual time:
the speed loop reaches and holds a speed, a silent planner stops the robot by the ramp without a
latched STOP, a stale command is never sent, and only `~/enable` arms the robot."""

from __future__ import annotations

import pytest

from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode, Gear, MovementCommand
from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.ros2 import diagnostics
from bywire.ros2.bridge import Activity
from bywire.ros2.settings import BridgeSettings
from bywire.teleop.frames import SEND_PERIOD_S
from tests.ros2.rig import ARMED_AT_S, Rig

TARGET_MPS = 0.5
TOLERANCE_MPS = 0.05
ENABLE_AT_S = ARMED_AT_S
DRIVE_FROM_S = 0.6


def _enable(rig: Rig, at_s: float) -> list[int]:
    numbers: list[int] = []
    rig.at(at_s, lambda: numbers.append(rig.link.request_enable()))
    return numbers


def _settle_end(rig: Rig, speeds_after_s: float) -> float:
    """When the robot's speed last left the band around the target (the settling time)."""
    outside = [
        s.time_s
        for s in rig.samples
        if s.time_s >= speeds_after_s and abs(s.speed_mps - TARGET_MPS) > TOLERANCE_MPS
    ]
    return max(outside, default=speeds_after_s)


@pytest.mark.parametrize("key", [None, SecocKey(bytes(range(16)))], ids=["plain", "secoc"])
def test_the_robot_reaches_and_holds_half_a_metre_per_second(key: SecocKey | None) -> None:
    rig = Rig.build(key=key)
    rig.start()
    numbers = _enable(rig, ENABLE_AT_S)
    rig.publish(TARGET_MPS, DRIVE_FROM_S, 8.0)
    rig.run_until(8.0)

    answer = rig.link.answer(numbers[0], 0.0)
    assert answer is not None
    assert answer.armed, answer.message
    speeds = rig.speeds(5.0, 8.0)
    assert min(speeds) >= TARGET_MPS - TOLERANCE_MPS
    assert max(speeds) <= TARGET_MPS + TOLERANCE_MPS
    assert _settle_end(rig, DRIVE_FROM_S) < DRIVE_FROM_S + 3.0
    snapshot = rig.link.snapshot()
    assert snapshot.pose.speed_mps == pytest.approx(TARGET_MPS, abs=TOLERANCE_MPS)
    truth = rig.world.vehicle.state
    assert snapshot.pose.x_m == pytest.approx(truth.x_m, abs=0.05)
    assert rig.modes(ENABLE_AT_S + 0.2) == {ControlMode.CAN}


def test_a_silent_planner_ramps_to_standstill_and_nothing_latches() -> None:
    settings = BridgeSettings(stop_ramp_s=0.3)
    rig = Rig.build(settings)
    rig.start()
    _enable(rig, ENABLE_AT_S)
    silent_from_s = 5.0
    rig.publish(TARGET_MPS, DRIVE_FROM_S, silent_from_s)
    rig.run_until(8.0)

    last_command_s = max(s.time_s for s in rig.samples if s.time_s < silent_from_s) - 0.05
    stopped = [s.time_s for s in rig.samples if s.time_s > silent_from_s and s.speed_mps == 0.0]
    assert rig.speeds(silent_from_s - 0.5, silent_from_s)[0] > TARGET_MPS - TOLERANCE_MPS
    limit_s = settings.cmd_timeout_s + settings.stop_ramp_s + 2 * SEND_PERIOD_S
    assert stopped[0] - last_command_s <= limit_s
    assert rig.speeds(stopped[0], 8.0) == [0.0] * len(rig.speeds(stopped[0], 8.0))
    assert rig.modes(ENABLE_AT_S + 0.2) == {ControlMode.CAN}  # no CAN timeout, no latch
    assert not any(s.latched for s in rig.samples if s.time_s > ENABLE_AT_S + 0.2)
    assert rig.link.snapshot().decision.activity is Activity.STOPPING  # type: ignore[union-attr]
    assert all(m.throttle_norm == 0.0 for m in rig.movements(silent_from_s + 0.25))


def test_a_command_whose_stamp_is_older_than_the_limit_is_never_sent() -> None:
    settings = BridgeSettings()
    rig = Rig.build(settings)
    rig.start()
    _enable(rig, ENABLE_AT_S)
    rig.publish(TARGET_MPS, DRIVE_FROM_S, 3.0, stamp_lag_s=settings.max_stamp_age_s + 0.01)
    rig.run_until(3.0)

    movements = rig.movements()
    assert len(movements) > 100
    assert all(m.throttle_norm == 0.0 and m.brake_norm > 0.0 for m in movements)
    assert max(rig.speeds(0.0, 3.0)) == 0.0
    assert rig.link.snapshot().health.refused >= 40
    throttle_volts = [v for _t, channel, v in rig.world.dac.history if channel == 0]
    assert max(throttle_volts) == 0.0


def test_a_command_that_ages_past_its_stamp_limit_stops_being_sent() -> None:
    """Fresh on arrival, but only just: its stamp ages past the limit while it is held."""
    settings = BridgeSettings(cmd_timeout_s=1.0, max_stamp_age_s=0.1)
    rig = Rig.build(settings)
    rig.start()
    _enable(rig, ENABLE_AT_S)
    lag_s, period_s = 0.05, 0.5
    rig.publish(TARGET_MPS, DRIVE_FROM_S, 3.0, stamp_lag_s=lag_s, period_s=period_s)
    rig.run_until(3.0)

    movement_id = dbc.frame_id(MovementCommand)
    driving_s = [
        frame.time_s
        for frame in rig.sent
        if frame.arbitration_id == movement_id
        and dbc.decode_command(movement_id, frame.data, None).throttle_norm > 0.0  # type: ignore[union-attr]
    ]
    assert driving_s  # each message drives while its stamp is young enough ...
    life_s = settings.max_stamp_age_s - lag_s
    wire_s = 0.001  # a frame's time is when its last bit left the wire
    for sent_s in driving_s:  # ... and is never sent once its stamp is older than the limit
        since_message_s = (sent_s - DRIVE_FROM_S) % period_s
        assert since_message_s <= life_s + wire_s


def test_commands_never_enable_the_robot_only_the_service_does() -> None:
    rig = Rig.build()
    rig.start()
    rig.publish(TARGET_MPS, DRIVE_FROM_S, 3.0)
    rig.run_until(3.0)

    assert max(rig.speeds(0.0, 3.0)) == 0.0
    assert all(m.throttle_norm == 0.0 for m in rig.movements())
    controls = [f for f in rig.sent if f.arbitration_id == 0x100]
    assert all(f.data[0] & 0b10 == 0 for f in controls)  # re_enable never set
    assert rig.link.snapshot().decision.activity is Activity.DISENGAGED  # type: ignore[union-attr]


def test_enable_arms_the_robot_after_a_remote_stop_and_diagnostics_name_the_cause() -> None:
    rig = Rig.build()
    rig.start()
    _enable(rig, ENABLE_AT_S)
    rig.publish(TARGET_MPS, DRIVE_FROM_S, 6.0)
    rig.at(2.0, lambda: rig.link.set_remote_stop(True))
    refused: list[int] = _enable(rig, 2.5)  # remote stop still on: refused at once
    seen: list[list[diagnostics.Status]] = []

    def look() -> None:
        snapshot = rig.link.snapshot()
        seen.append(
            diagnostics.statuses(
                snapshot.status,
                snapshot.health,
                snapshot.robot_status_report,
                engaged=snapshot.engaged,
                remote_stop=snapshot.remote_stop,
            )
        )

    rig.at(2.8, look)
    rig.at(3.0, lambda: rig.link.set_remote_stop(False))
    armed: list[int] = _enable(rig, 3.2)
    rig.run_until(6.0)

    assert rig.modes(2.1, 3.2) == {ControlMode.STOP}
    no = rig.link.answer(refused[0], 0.0)
    assert no is not None
    assert not no.armed
    assert "remote stop is on" in no.message
    mode_status = seen[0][0]
    assert mode_status.level is diagnostics.Level.ERROR
    assert "REMOTE_STOP" in mode_status.message
    commands = next(s for s in seen[0] if s.name == "bywire: CAN commands")
    assert ("REMOTE_STOP", "latched") in commands.values
    yes = rig.link.answer(armed[0], 0.0)
    assert yes is not None
    assert yes.armed, yes.message
    assert rig.modes(3.5, 6.0) == {ControlMode.CAN}
    assert min(rig.speeds(5.5, 6.0)) > TARGET_MPS - TOLERANCE_MPS


def test_enable_says_why_not_when_the_transmitter_selects_rc() -> None:
    rig = Rig.build()
    rig.start()
    rig.at(0.5, lambda: rig.world.rc.set_mode(ControlMode.RC))
    numbers = _enable(rig, 1.0)
    rig.run_until(2.5)

    answer = rig.link.answer(numbers[0], 0.0)
    assert answer is not None
    assert not answer.armed
    assert "RC mode" in answer.message


def test_a_change_of_direction_stops_first_then_reverses() -> None:
    rig = Rig.build()
    rig.start()
    _enable(rig, ENABLE_AT_S)
    rig.publish(TARGET_MPS, DRIVE_FROM_S, 4.0)
    rig.publish(-0.3, 4.0, 9.0)
    rig.run_until(9.0)

    assert min(rig.speeds(8.0, 9.0)) < -0.25
    assert rig.gear() is Gear.REVERSE
    reverse_from = min(s.time_s for s in rig.samples if s.speed_mps < 0.0)
    assert max(rig.speeds(4.0, reverse_from)) <= TARGET_MPS + TOLERANCE_MPS
    assert rig.modes(ENABLE_AT_S + 0.2, 9.0) == {ControlMode.CAN}
    assert ErrorFlag.CAN_COMMAND_REJECTED not in rig.link.snapshot().status.flags
