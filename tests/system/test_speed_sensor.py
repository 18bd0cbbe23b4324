"""A wheel sensor that dies while a computer drives in CAN mode (issue 41 finding 6): the
controller's own check flags SPEED_SENSOR_FAULT, and from then on takes no CAN throttle, so a
computer that ignores the flag (and sees the dead sensor's 0 m/s) cannot run the robot away."""

from __future__ import annotations

from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode
from tests.system.test_stop_gets_through import DRIVING_BY_CAN, played

SENSOR_DIES_S = 3.0


def test_a_computer_ignoring_a_dead_wheel_sensor_gets_no_throttle_once_it_is_flagged() -> None:
    run = played(
        DRIVING_BY_CAN.replace("THROTTLE", "0.64")
        + f"""
[[event]]
at_s = {SENSOR_DIES_S}
fault = "wheel_sensor_dead"
""",
        10.0,
    )
    samples = list(run.record.samples)
    flagged_s = min(
        s.time_s
        for s in samples
        if s.time_s >= SENSOR_DIES_S and s.error_flags & ErrorFlag.SPEED_SENSOR_FAULT
    )
    assert flagged_s < SENSOR_DIES_S + 1.5  # the check noticed (row 27)
    after = [s for s in samples if s.time_s > flagged_s + 0.03]
    assert after
    assert all(s.throttle_volts == 0.0 for s in after)  # the computer still asks 0.64
    at_flag_mps = max(s.speed_mps for s in samples if abs(s.time_s - flagged_s) < 0.05)
    assert max(s.speed_mps for s in after) <= at_flag_mps
    assert after[-1].speed_mps < at_flag_mps - 0.5  # it coasts down: no runaway
    assert {s.mode for s in after} == {ControlMode.CAN}  # no stop: the computer may brake, steer
    assert all(s.throttle_cmd_norm == 0.0 for s in after)
