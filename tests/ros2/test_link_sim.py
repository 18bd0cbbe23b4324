"""The bridge drives the whole simulated robot (real controller, real frames) on virtual time:
the speed loop reaches and holds a speed, a silent planner stops the robot by the ramp without a
latched STOP, a stale command is never sent, and only `~/enable` arms the robot."""

from __future__ import annotations

from collections.abc import Callable

import can
import pytest

from bywire.error_flags import ErrorFlag
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.model import ControlMode, Gear, MovementCommand, WheelSpeedReport
from bywire.protocol import dbc
from bywire.protocol.secoc import SecocKey
from bywire.ros2 import diagnostics, stop_ramp
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
        and dbc.decode_command(movement_id, frame.data, None).throttle_norm > 0.0  # type: ignore[attr-defined]
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


def _look(rig: Rig) -> list[diagnostics.Status]:
    snapshot = rig.link.snapshot()
    return diagnostics.statuses(
        snapshot.status,
        snapshot.health,
        snapshot.robot_status_report,
        engaged=snapshot.engaged,
        remote_stop=snapshot.remote_stop,
    )


@pytest.mark.parametrize(
    "cruise_mps",
    [0.5, 0.3],
    ids=["dies-at-0.5-read-as-a-jump", "dies-at-0.3-read-as-stuck-after-1s"],
)
def test_a_wheel_sensor_dying_while_driving_stops_the_robot_not_runs_it_away(
    cruise_mps: float,
) -> None:
    """Issue 41 finding 6: the sensor reads 0 from 4 s on. The controller flags
    SPEED_SENSOR_FAULT and stays in CAN mode; the bridge, seeing the flag, asks no throttle from
    the next period and brakes fully for `blind_brake_s`: the robot stands, never faster than
    when the flag came (the old loop held 0.64 throttle: 2.36 m/s after 8 s and rising)."""
    settings = BridgeSettings()
    rig = Rig.build(settings)
    rig.start()
    _enable(rig, ENABLE_AT_S)
    dies_s, end_s = 4.0, 12.0
    rig.publish(cruise_mps, DRIVE_FROM_S, end_s)
    rig.at(dies_s, rig.world.wheel_sensor.die)
    rig.run_until(end_s)

    flagged_s = rig.first(ErrorFlag.SPEED_SENSOR_FAULT, dies_s)
    assert flagged_s < dies_s + 1.5  # the controller's own check (row 27) noticed it
    seen_s = flagged_s + 3 * SEND_PERIOD_S  # the ErrorReport, then the bridge's next period
    at_flag_mps = max(rig.speeds(flagged_s - 0.01, flagged_s + 0.01))
    assert max(rig.speeds(seen_s, end_s)) <= at_flag_mps + 0.01
    standing_s = seen_s + stop_ramp.blind_brake_s(settings)
    assert rig.speeds(standing_s, end_s) == [0.0] * len(rig.speeds(standing_s, end_s))
    assert rig.throttle_volts(seen_s + SEND_PERIOD_S) == [0.0]
    assert all(m.throttle_norm == 0.0 for m in rig.movements(seen_s))
    assert all(m.brake_norm == 1.0 for m in rig.movements(seen_s)[:10])
    assert rig.modes(ENABLE_AT_S + 0.2) == {ControlMode.CAN}
    decision = rig.link.snapshot().decision
    assert decision is not None
    assert decision.activity is Activity.BLIND
    mode = _look(rig)[0]
    assert mode.level is diagnostics.Level.ERROR
    assert "SPEED_SENSOR_FAULT" in mode.message


class _DeafTo:
    """The link's bus, deaf to one report from `from_s` on (a report that stopped arriving)."""

    def __init__(self, bus: can.BusABC, frame_id: int, from_s: float, now: Callable[[], float]):
        self.bus, self.frame_id, self.from_s, self.now = bus, frame_id, from_s, now

    def recv(self, timeout: float | None = None) -> can.Message | None:
        while True:
            message = self.bus.recv(timeout)
            lost = message is not None and message.arbitration_id == self.frame_id
            if not (lost and self.now() >= self.from_s):
                return message

    def __getattr__(self, name: str) -> object:
        return getattr(self.bus, name)


def test_wheel_speed_reports_that_stop_arriving_brake_the_robot_to_standstill() -> None:
    """Issue 41 finding 6, the stale speed: the wheel-speed report stops reaching the bridge at
    1 m/s; the robot is still in CAN mode and the commands go on. Not the holding brake (0.1 here:
    the robot coasted for seconds) but full brake for `blind_brake_s`, throttle 0."""
    settings = BridgeSettings(hold_brake=0.1)
    rig = Rig.build(settings)
    lost_s, end_s = 5.0, 9.0
    rig.link.bus = _DeafTo(  # type: ignore[assignment]
        rig.link.bus, dbc.frame_id(WheelSpeedReport), lost_s, rig.clock.now
    )
    rig.start()
    _enable(rig, ENABLE_AT_S)
    rig.publish(1.0, DRIVE_FROM_S, end_s)
    rig.run_until(end_s)

    assert min(rig.speeds(lost_s - 0.5, lost_s)) > 0.9
    stale_s = lost_s + settings.report_timeout_s + SEND_PERIOD_S
    assert all(m.throttle_norm == 0.0 for m in rig.movements(stale_s))
    assert rig.throttle_volts(stale_s + SEND_PERIOD_S) == [0.0]
    standing_s = stale_s + stop_ramp.blind_brake_s(settings)
    assert rig.speeds(standing_s, end_s) == [0.0] * len(rig.speeds(standing_s, end_s))
    assert rig.modes(ENABLE_AT_S + 0.2) == {ControlMode.CAN}


@pytest.mark.parametrize(
    ("max_speed_mps", "cruise_mps", "silent_s"),
    [(2.0, 2.0, 8.0), (3.0, 2.9, 12.0)],
    ids=["2.0", "2.9"],
)
def test_the_stop_ramp_brakes_until_the_robot_stands(
    max_speed_mps: float, cruise_mps: float, silent_s: float
) -> None:
    """Issue 41 finding 7: at 2 m/s (2.9), full brake cannot follow a 0.3 s ramp's line. The old
    ramp dropped to the 0.1 holding brake at the line's end with the robot rolling at 0.64 m/s
    (1.20): it coasted 1.5 m (3.5 m). Now the brake stays on until the robot reports standstill,
    which it reaches within `stop_bound_s` of the ramp's start."""
    settings = BridgeSettings(stop_ramp_s=0.3, hold_brake=0.1, max_speed_mps=max_speed_mps)
    rig = Rig.build(settings)
    rig.start()
    _enable(rig, ENABLE_AT_S)
    rig.publish(cruise_mps, DRIVE_FROM_S, silent_s)
    rig.run_until(silent_s + 4.0)

    at_silence_mps = rig.speeds(silent_s - 0.02, silent_s)[0]
    assert at_silence_mps > cruise_mps - 0.45
    ramp_s = silent_s + settings.cmd_timeout_s + SEND_PERIOD_S  # the first period without one
    bound_s = stop_ramp.stop_bound_s(at_silence_mps, settings) + SEND_PERIOD_S
    stood = [s.time_s for s in rig.samples if s.time_s > silent_s and s.speed_mps == 0.0]
    standing_s = min(stood, default=float("inf"))
    assert standing_s <= ramp_s + bound_s
    distance = sum(rig.speeds(ramp_s, silent_s + 4.0)) * 0.01
    assert distance <= at_silence_mps * bound_s
    held = [m.brake_norm for m in rig.movements(ramp_s) if m.brake_norm < 1.0]
    assert set(held) == {settings.hold_brake}  # then held, at standstill only
    let_go_s = min(f.time_s for f in rig.sent if f.time_s > ramp_s and _brake(f) < 1.0)
    assert let_go_s >= standing_s  # full brake until the robot stood
    assert rig.modes(ENABLE_AT_S + 0.2) == {ControlMode.CAN}


def _brake(frame: LoggedFrame) -> float:
    movement_id = dbc.frame_id(MovementCommand)
    if frame.arbitration_id != movement_id:
        return 1.0
    command = dbc.decode_command(movement_id, frame.data, None)
    assert isinstance(command, MovementCommand)
    return command.brake_norm


def test_a_lagging_stamp_that_stalls_the_robot_is_counted_shown_and_logged_once() -> None:
    """Issue 41 finding 8: stamps 0.17 s old at arrival, at 20 Hz: each command ages past
    `max_stamp_age_s` (0.2) before the next one comes, so the robot never moves. Every such
    command is now counted with its reason; `bywire: inputs` turns WARN at once and ERROR once
    none has been accepted for `REFUSING_S`; a planner with fresh stamps then drives, and the
    status goes back. One log line per change of level, not one per command."""
    rig = Rig.build()
    rig.start()
    _enable(rig, ENABLE_AT_S)
    lagging_until_s, end_s = 3.0, 9.5
    rig.publish(TARGET_MPS, DRIVE_FROM_S, lagging_until_s, stamp_lag_s=0.17)
    rig.publish(TARGET_MPS, lagging_until_s, end_s)
    seen: list[tuple[float, list[diagnostics.Status], int]] = []

    def look() -> None:
        snapshot = rig.link.snapshot()
        seen.append((rig.clock.now(), _look(rig), snapshot.health.refused))

    for second in range(1, 19):  # as the node: /diagnostics twice a second here
        rig.at(DRIVE_FROM_S + 0.5 * second, look)
    rig.run_until(end_s)

    assert max(rig.speeds(0.0, lagging_until_s)) == 0.0  # stalled, as the rule says ...
    arrived = round((lagging_until_s - DRIVE_FROM_S) / 0.05)
    refused_then = next(refused for at_s, _s, refused in seen if at_s >= lagging_until_s)
    assert refused_then >= arrived - 1  # ... but not silently: each command counted
    health = rig.link.snapshot().health
    assert dict(health.refused_by_reason)["STAMP_OLD"] >= arrived - 1  # with its reason
    levels = {
        round(at_s - DRIVE_FROM_S, 1): inputs_of(statuses).level for at_s, statuses, _ in seen
    }
    assert levels[0.5] is diagnostics.Level.WARN
    assert levels[1.5] is diagnostics.Level.ERROR
    assert levels[2.0] is diagnostics.Level.ERROR
    error = inputs_of(next(s for at_s, s, _ in seen if at_s - DRIVE_FROM_S > 1.4))
    assert "header stamp older than max_stamp_age_s" in error.message
    assert min(rig.speeds(end_s - 1.0, end_s)) > TARGET_MPS - TOLERANCE_MPS  # fresh: it drives
    assert levels[3.0] is diagnostics.Level.WARN  # accepted again, the refusals still recent
    assert levels[8.5] is diagnostics.Level.OK
    logged: dict[str, diagnostics.Level] = {}
    lines: list[str] = []
    for _at_s, statuses, _refused in seen:
        logged, new = diagnostics.log_lines(logged, statuses)
        lines += [line for _level, line in new if line.startswith("bywire: inputs")]
    assert [line.split(":")[1] for line in lines] == [
        " inputs WARN",
        " inputs ERROR",
        " inputs WARN",
        " inputs OK",
    ]
    assert seen[-1][2] < arrived + 5  # nothing counted once the stamps are fresh


def inputs_of(statuses: list[diagnostics.Status]) -> diagnostics.Status:
    return next(s for s in statuses if s.name == "bywire: inputs")
