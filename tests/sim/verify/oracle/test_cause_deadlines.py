"""The oracle's figures come from the requirements, never from the robot file under test
(R-CONFIG-SAFETY): a file that configures a gentler handover, a shorter controlled stop or a
weaker one is judged by the same figures; a file's timeouts and task periods may tighten the
deadlines it is held to (its own promise), never loosen them past the requirement's."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import pytest

from bywire.config import default_sim_config, parse_config
from bywire.config.limits import CONTROLLED_STOP_S, HANDOVER_RATE, INPUT_TIMEOUT_S, WATCHDOG_S
from bywire.control import supervisor
from bywire.model import ControlMode
from bywire.sim.runner import SimRun
from bywire.sim.verify.campaign import Campaign, Step, compile_steps
from bywire.sim.verify.engine import run_campaign
from bywire.sim.verify.oracle import OracleCause, OracleTiming
from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import (
    CONTROLLED_STOP_LIMIT_S,
    REQUIRED,
    REQUIRED_HANDOVER_RATE,
    Figure,
)

BASE = 'backend = "sim"\n'
OWN_FIGURES = (
    BASE + "[steering]\nhandover_rate_norm_per_s = 0.05\n\n"
    "[stop]\ncontrolled_max_s = 2.0\ncontrolled_min_decel_mps2 = 1.5\n"  # the most it may
)


def test_a_robot_file_s_own_stop_and_handover_figures_do_not_reach_the_oracle() -> None:
    ordinary = OracleTiming.for_robot(parse_config(BASE, "<ordinary>"))
    own = OracleTiming.for_robot(parse_config(OWN_FIGURES, "<own figures>"))
    assert own == ordinary


def test_the_requirement_figures_are_the_most_a_robot_file_may_set() -> None:
    assert HANDOVER_RATE.high == REQUIRED_HANDOVER_RATE
    assert CONTROLLED_STOP_S.high == CONTROLLED_STOP_LIMIT_S


LAX = (
    BASE + "[timeouts]\nrc_timeout_s = 0.3\ncan_command_timeout_s = 0.3\nwatchdog_s = 0.5\n\n"
    "[timeouts.can_message_timeout_s]\nMovementCommand = 0.3\n"
)
"""Timeouts the loader takes (each in its range, none longer than the watchdog), three times
the requirements' defaults (R-TIMEOUT 100 ms, R-WATCHDOG 200 ms)."""


def test_a_robot_file_is_held_to_its_own_timeouts_within_the_loader_s_limits() -> None:
    lax = OracleTiming.for_robot(parse_config(LAX, "<lax>"))
    assert (lax.rc_timeout_s, lax.can_timeout_s, lax.watchdog_s) == (0.3, 0.3, 0.5)
    lost = OracleCause.RC_LINK_LOST
    assert lax.deadline_s(lost) - OracleTiming().deadline_s(lost) == pytest.approx(0.2)


def test_a_timeout_past_the_loader_s_limits_is_judged_at_the_limit() -> None:
    # A RobotConfig built in code skips the loader: the oracle still holds it to the limits.
    robot = default_sim_config()
    timeouts = replace(robot.timeouts, rc_timeout_s=3.0, watchdog_s=30.0)
    timing = OracleTiming.for_robot(replace(robot, timeouts=timeouts))
    assert timing.rc_timeout_s == REQUIRED[Figure.RC_TIMEOUT_S].most == INPUT_TIMEOUT_S.high
    assert timing.watchdog_s == REQUIRED[Figure.WATCHDOG_S].most == WATCHDOG_S.high


def test_a_robot_file_with_slow_tasks_gets_the_requirement_s_period() -> None:
    slow = BASE + "[tasks]\nsteering_rate_hz = 100\ndriving_rate_hz = 50\nhydrobrake_rate_hz = 25\n"
    timing = OracleTiming.for_robot(parse_config(slow, "<slow tasks>"))
    assert timing.control_period_s == REQUIRED[Figure.CONTROL_PERIOD_S].most == 0.02  # not 40 ms
    assert timing.driving_period_s == pytest.approx(0.02)


def test_a_tighter_timeout_tightens_the_deadline_it_is_held_to() -> None:
    quick = parse_config(BASE + "[timeouts]\nrc_timeout_s = 0.05\n", "<quick link>")
    lost = OracleCause.RC_LINK_LOST
    shift_s = OracleTiming.for_robot(quick).deadline_s(lost) - OracleTiming().deadline_s(lost)
    assert shift_s == pytest.approx(-0.05)


RC_LOST_WHILE_DRIVING = [
    Step(0.2, "arm", ControlMode.RC),
    Step(0.15, "rc_throttle", 0.6),
    Step(1.0, "rc_link", False),
]


def test_a_lax_rc_timeout_is_judged_by_its_own_promise() -> None:
    # The receiver unplugged while driving: the file's 0.3 s timeout keeps the throttle on for
    # 0.3 s, as it promised (the requirement gives 100 ms as a default, not a bound).
    assert run_campaign(parse_config(LAX, "<lax>"), RC_LOST_WHILE_DRIVING).findings == []


def test_a_stop_a_frame_carries_is_judged_at_the_promise_whatever_the_file_declares() -> None:
    # Issue 41: the frame, one control period, and the drive's two transfers (a controlled
    # stop's throttle and regeneration), the transfers bounded by what the promise leaves.
    default = OracleTiming.for_robot(default_sim_config())
    assert default.deadline_s(OracleCause.SWITCH_STOP) == pytest.approx(0.0077 + 0.010 + 2 * 0.0035)
    bench = parse_config(
        "[timeouts]\nstop_response_s = 0.06\npass_budget_s = 0.05\ndac_transfer_budget_s = 0.02",
        "bench.toml",
    )
    judged = OracleTiming.for_robot(bench)
    assert judged.dac_transfer_s == pytest.approx(0.0072 / 2, abs=1e-4)
    assert judged.deadline_s(OracleCause.SWITCH_STOP) < 0.0077 + 0.010 + 0.008


# --- the RC sticks' deadbands (docs/SAFETY.md row 65) --------------------------------------------

WIDE_DEADBAND = BASE + "[rc.throttle_brake]\ndeadband_norm = 0.2202\n"
"""Found by `bywire verify --draw-robots` (issue 41, finding C): legal (0..0.5)."""


def _run_recording(
    robot_toml: str, stick_norm: float, then: list[Step] | None = None
) -> tuple[list[Outputs], list[Violation]]:
    """From STOP, the throttle stick at `stick_norm` and the switch to RC at 1.3 s (then
    `then`): every pass's hardware, and what the oracle flagged."""
    robot = parse_config(robot_toml, "<robot>")
    steps = [Step(1.3, "rc_throttle", stick_norm), Step(0.0, "switch", ControlMode.RC)]
    seen: list[Outputs] = []

    def record(run: SimRun) -> None:
        run.runtime.on_cycle.append(lambda _now: seen.append(Outputs.read(run.world)))

    result = Campaign(robot).run_scenario(compile_steps([*steps, *(then or [])], robot), record)
    return seen, result.oracle.violations


def test_a_stick_inside_the_throttle_deadband_arms_at_zero_throttle_unflagged() -> None:
    # The stick at 0.2 reads zero on this robot: the switch to RC arms (spring brake released,
    # motors enabled) at 0 V and the robot stands; the oracle took the stick for throttle and
    # flagged the arming (H1).
    seen, violations = _run_recording(WIDE_DEADBAND, 0.2)
    assert seen[-1].enable  # armed
    assert seen[-1].released
    assert max(out.throttle_volts for out in seen) == 0.0
    assert max(abs(out.speed_mps) for out in seen) == 0.0
    assert violations == [], violations[:1]


def test_after_arming_inside_the_deadband_the_stick_past_it_drives_unflagged() -> None:
    seen, violations = _run_recording(WIDE_DEADBAND, 0.2, [Step(0.5, "rc_throttle", 0.8)])
    assert max(out.throttle_volts for out in seen) > 0.0
    assert max(out.speed_mps for out in seen) > OracleTiming().standstill_mps  # it moves
    assert violations == [], violations[:1]


def test_the_stick_just_outside_the_deadband_refuses_the_arming() -> None:
    # The correct controller: 0.25 is throttle on this robot, so the switch to RC does not arm.
    seen, violations = _run_recording(WIDE_DEADBAND, 0.25)
    assert not seen[-1].released
    assert max(out.throttle_volts for out in seen) == 0.0
    assert violations == [], violations[:1]


def test_an_arming_with_the_stick_just_outside_the_deadband_is_still_flagged(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Teeth: a controller that arms whatever the RC stick says; the stick at 0.25, just outside
    # the 0.2202 deadband, drives the robot off as the switch reaches RC.
    arming = supervisor._from_stop

    def arms_on_any_stick(state: Any, inputs: Any, *rest: Any) -> Any:
        return arming(state, replace(inputs, rc_throttle_zero=True), *rest)

    monkeypatch.setattr(supervisor, "_from_stop", arms_on_any_stick)
    seen, violations = _run_recording(WIDE_DEADBAND, 0.25)
    assert max(out.throttle_volts for out in seen if out.enable and out.released) > 0.0
    assert max(out.speed_mps for out in seen) > 0.0  # it moves off
    assert [violation.invariant for violation in violations[:1]] == [Invariant.H1]


@pytest.mark.parametrize(
    ("stick_norm", "read_norm"),
    # 0.2206 is sent as 1610 µs, read as 0.22 (inside); 0.2219 as 1611 µs, 0.222 (outside)
    [(0.0, 0.0), (0.2, 0.0), (-0.2, 0.0), (0.2206, 0.0), (0.2219, 0.2219), (-0.25, -0.25)],
)
def test_the_oracle_reads_the_sticks_through_the_file_s_deadbands(
    stick_norm: float, read_norm: float
) -> None:
    both = WIDE_DEADBAND + "\n[rc.steering]\ndeadband_norm = 0.2202\nreverse = true\n"
    sticks = OracleTiming.for_robot(parse_config(both, "<deadbands>")).sticks
    assert sticks.throttle.read_norm(stick_norm) == read_norm
    assert sticks.steering.read_norm(stick_norm) == read_norm
    # half a microsecond of the stick's shorter half (500 µs) past the edge may read zero
    assert sticks.throttle.rounding_norm == pytest.approx(0.001)
