"""Old behaviours of issue 10, and STOP levels gone wrong, each put back by monkeypatch: the
checks must find every one.

Each function takes pytest's `monkeypatch` and re-introduces one safety bug. Those of issue 10
are named by that issue's row (`row_…`), the others by the hazard table's row or the part of
STOP they break (`hazard_…`, `stop_…`, docs/SAFETY.md); `bywire verify`'s tests
(`tests/sim/verify/test_verify.py`, `tests/cli/test_verify.py`) put each back and find it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest

from bywire.control import controller, dac_health, mux, supervisor
from bywire.control.drive import drive_outputs
from bywire.control.input_stage import Decoded, MessageState, Verdict, message_step
from bywire.control.interlocks import interlock_step
from bywire.control.mux import Movement
from bywire.control.steering import steering_step
from bywire.control.supervisor import DRIVING_MODES, SupervisorState, supervisor_step
from bywire.model import ControlMode
from bywire.runtime import readers, write_gate

OldBug = Callable[[pytest.MonkeyPatch], None]


def row_23_a_can_re_enable_clears_every_cause(monkeypatch: pytest.MonkeyPatch) -> None:
    # Issue 10 row 1: the computer's re-enable cleared what only the operator may (a lost RC
    # link, failing DAC writes, a watchdog trip), and the robot drove on.
    monkeypatch.setattr(supervisor, "CAN_CLEARABLE", frozenset(supervisor.Cause))


def row_3_a_refused_arming_is_remembered(monkeypatch: pytest.MonkeyPatch) -> None:
    original = supervisor._from_stop

    def remembering(state: SupervisorState, inputs: Any, switch: Any, *rest: Any) -> Any:
        retry = state.ready and switch in DRIVING_MODES
        pretend = replace(state, switch=ControlMode.STOP) if retry else state
        after = original(pretend, inputs, switch, *rest)
        return replace(after, ready=True) if retry and after.mode is ControlMode.STOP else after

    monkeypatch.setattr(supervisor, "_from_stop", remembering)


def row_4_a_handover_without_the_throttle_gate(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(
        SupervisorState,
        "throttle_allowed",
        property(lambda self: self.mode is not ControlMode.STOP),
    )


def row_6_no_debounce(monkeypatch: pytest.MonkeyPatch) -> None:
    original, one_frame = supervisor.supervisor_step, supervisor.SupervisorConfig(1)

    def undebounced(state: SupervisorState, inputs: Any, _config: Any) -> SupervisorState:
        return original(state, inputs, one_frame)

    monkeypatch.setattr(controller, "supervisor_step", undebounced)


def row_7_only_consecutive_dac_failures_count(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dac_health, "DAC_LEAK", 1.0)  # one good write wipes the count


def row_8_a_write_in_flight_lands_after_the_trip(monkeypatch: pytest.MonkeyPatch) -> None:
    def unchecked(self: write_gate.WriteGate, port: str, action: Any) -> bool:
        if self.tripped:
            return False
        action()  # lands after the trip, and stands
        return True

    monkeypatch.setattr(write_gate.WriteGate, "write", unchecked)


def issue_30_an_unreadable_frame_restarts_the_sequence(monkeypatch: pytest.MonkeyPatch) -> None:
    # dce19d3's reader: a frame the codec could not read started the sequence afresh, so a
    # forgery carrying the counter just used, right after a bad CRC, was accepted (issue 30,
    # finding 1: full right lock at 0.78 m/s, the id never untrusted).
    def restarting(
        state: MessageState, frame: Decoded, at: float, timeout: float
    ) -> tuple[MessageState, Verdict]:
        if not frame.readable:
            return MessageState(window=state.window, untrusted=state.untrusted), Verdict.UNREADABLE
        return message_step(state, frame, at, timeout)

    monkeypatch.setattr(readers, "message_step", restarting)


def hazard_10_a_re_enable_forgives_a_second_sender(monkeypatch: pytest.MonkeyPatch) -> None:
    # The computer's re-enable clears CAN_UNTRUSTED once the id is trusted again: whoever sent
    # the second frames may send the re-enable too (hazard row 10; S8: the switch's to clear).
    untrusted = supervisor.Cause.CAN_UNTRUSTED
    monkeypatch.setattr(supervisor, "CAN_CLEARABLE", supervisor.CAN_CLEARABLE | {untrusted})


def hazard_6_stop_spares_the_hydraulic_brake(monkeypatch: pytest.MonkeyPatch) -> None:
    # "The spring brake holds in STOP, spare the pump": with the e-brake broken (hazard row 6)
    # nothing stops a rolling robot.
    monkeypatch.setattr(mux, "STOPPED", replace(mux.STOPPED, brake_norm=0.0))


def hazard_20_throttle_beats_brake(monkeypatch: pytest.MonkeyPatch) -> None:
    # Throttle and brake asked together both reach the motors (hazard row 20: brake beats it).
    def interlock(state: Any, wanted: Movement, *rest: Any) -> Any:
        after, movement, held = interlock_step(state, replace(wanted, brake_norm=0.0), *rest)
        return after, replace(movement, brake_norm=wanted.brake_norm), held

    def drive(movement: Movement, enabled: bool, config: Any) -> Any:
        outputs = drive_outputs(movement, enabled, config)
        unbraked = drive_outputs(replace(movement, brake_norm=0.0), enabled, config)
        return replace(outputs, throttle_volts=unbraked.throttle_volts)

    monkeypatch.setattr(controller, "interlock_step", interlock)
    monkeypatch.setattr(controller, "drive_outputs", drive)


def hazard_19_the_interlock_takes_the_robot_for_standing(monkeypatch: pytest.MonkeyPatch) -> None:
    # The direction interlock's dwell runs on zero throttle alone, as if the wheels stood still:
    # reverse engages while the robot still rolls forward (hazard row 19).
    def standing(state: Any, wanted: Movement, speed_mps: float | None, *rest: Any) -> Any:
        return interlock_step(state, wanted, 0.0, *rest)

    monkeypatch.setattr(controller, "interlock_step", standing)


def hazard_19_the_interlock_trusts_a_distrusted_speed(monkeypatch: pytest.MonkeyPatch) -> None:
    # The speed check catches the dead wheel sensor, and the interlock uses its 0 m/s anyway:
    # reverse engages while the robot still rolls (hazard row 19, `wheel-sensor-dead`).
    monkeypatch.setattr(controller, "trusted_speed", lambda _state, speed: speed)


def hazard_19_an_arming_makes_a_dead_sensor_trusted(monkeypatch: pytest.MonkeyPatch) -> None:
    # The speed check before 2026-11-25: only a latched fault distrusts the sensor, and the
    # arming that clears it makes the dead sensor's standstill count while the robot rolls.
    monkeypatch.setattr(
        controller, "trusted_speed", lambda state, speed: None if state.faulted else speed
    )


def issue_30_the_steering_takes_over_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    # dce19d3: a handover was bumpless for the throttle only; the new source's steering was
    # taken at the ordinary rate (0.71 of full lock within 0.5 s at 1.6 m/s).
    def at_once(*args: Any, **options: Any) -> Any:
        return steering_step(*args, **{**options, "handover": False})

    monkeypatch.setattr(controller, "steering_step", at_once)


def stop_centres_the_steering(monkeypatch: pytest.MonkeyPatch) -> None:
    # In STOP the steering turns back to the centre: at speed, a swerve (STOP holds it).
    mode = [ControlMode.STOP]

    def watched(*args: Any) -> SupervisorState:
        after = supervisor_step(*args)
        mode[0] = after.mode
        return after

    def centring(state: Any, target_norm: float, *rest: Any, **options: Any) -> Any:
        target = 0.0 if mode[0] is ControlMode.STOP else target_norm
        return steering_step(state, target, *rest, **options)

    monkeypatch.setattr(controller, "supervisor_step", watched)
    monkeypatch.setattr(controller, "steering_step", centring)


OLD_BUGS: dict[str, OldBug] = {
    bug.__name__: bug
    for bug in (
        row_23_a_can_re_enable_clears_every_cause,
        row_3_a_refused_arming_is_remembered,
        row_4_a_handover_without_the_throttle_gate,
        row_6_no_debounce,
        row_7_only_consecutive_dac_failures_count,
        row_8_a_write_in_flight_lands_after_the_trip,
        issue_30_an_unreadable_frame_restarts_the_sequence,
        hazard_10_a_re_enable_forgives_a_second_sender,
        hazard_6_stop_spares_the_hydraulic_brake,
        hazard_19_the_interlock_takes_the_robot_for_standing,
        hazard_19_the_interlock_trusts_a_distrusted_speed,
        hazard_19_an_arming_makes_a_dead_sensor_trusted,
        hazard_20_throttle_beats_brake,
        stop_centres_the_steering,
        issue_30_the_steering_takes_over_at_once,
    )
}
