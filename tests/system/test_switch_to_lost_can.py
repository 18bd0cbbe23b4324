"""A slow receiver's move to a CAN that cannot drive (docs/SAFETY.md row 74, found by
`bywire verify --draw-robots 24 --budget 2400 --seed 4`, file 22, campaign 1, H1): a legal
10 Hz receiver (`sim.rc_frame_period_s = 0.1`), the robot armed in RC, a keyed second sender
making CAN untrusted, then the switch moved RC -> CAN. The controller counts the move after the
debounce's frames (3 x 100 ms), as it counts every move away from STOP (row 26), so it stayed
in RC, then stopped as it entered a CAN it could not trust: the oracle had demanded the stop
by CAN's own deadline from the move, 150 ms, as if the move counted at once. The controller
was right; the oracle now counts such a stop from when the move counts. Judged on the enable
line, the e-brake line, the throttle volts and the true speed, with the oracle's teeth: a
controller one frame slower than the debounce is still found."""

from __future__ import annotations

import pytest

from bywire.config import parse_config
from bywire.control import supervisor
from bywire.sim.observe import Observation
from bywire.sim.verify.oracle.causes import OracleCause
from bywire.sim.verify.oracle.judge import HazardOracle
from tests.sim.verify.mutants import can_loss_never_latches, one_frame_late
from tests.system.judged import Judged, judged

SLOW_RECEIVER = parse_config(
    "[timeouts]\nrc_timeout_s = 1.0\nwatchdog_s = 5.0\n\n[sim]\nrc_frame_period_s = 0.1\n",
    "file-22",
)
FRAME_S = 0.1
MOVE_S = 3.345
COUNTS_S = MOVE_S + SLOW_RECEIVER.supervisor.debounce_frames * FRAME_S  # the debounce's frames
SLACK_S = 0.01 + 0.012  # a control period and the frame's wire time (`OracleTiming.settle_s`)


def found(*extra: str) -> str:
    """The campaign as shrunk (file 22, seed 4, campaign 1), and `extra` events."""
    events = [
        '{ at_s = 0.0, rc = { gear = "forward" } }',
        '{ at_s = 0.0, hlc = { steering = 0.0, throttle = 0.0, brake = 0.0, gear = "forward" } }',
        '{ at_s = 1.8, rc = { throttle = 0.0, mode = "rc" } }',
        "{ at_s = 2.1, hlc = { throttle = 0.0 } }",
        '{ at_s = 2.145, rc = { mode = "can" } }',
        '{ at_s = 2.4, rc = { throttle = 0.0, mode = "rc" } }',
        '{ at_s = 3.2, fault = "can_impostor", count = 15, keyed = true }',
        "{ at_s = 3.3, hlc = { steering = -0.9, throttle = 0.0 } }",
        f'{{ at_s = {MOVE_S}, rc = {{ mode = "can" }} }}',
        *extra,
    ]
    joined = ",\n    ".join(events)
    return f'name = "file-22"\nduration_s = 4.2\nevent = [\n    {joined},\n]\n'


def played(scenario: str) -> Judged:
    return judged(SLOW_RECEIVER, scenario)


def _stopped(sample: Observation) -> bool:
    """Safe as H1 asks: the spring brake on, no throttle volts (a controlled stop of a rolling
    robot may keep the drive powered to brake)."""
    return sample.ebrake_engaged and sample.throttle_volts == 0.0


def test_the_move_to_an_untrusted_can_stops_once_the_debounce_has_counted_it() -> None:
    run = played(found())
    assert run.found == set()
    armed = [s for s in run.after(2.5) if s.time_s < MOVE_S]
    assert all(s.motors_enabled and not s.ebrake_engaged for s in armed)  # RC armed
    after = run.after(COUNTS_S + SLACK_S)
    assert all(_stopped(s) and not s.motors_enabled for s in after)  # at standstill
    assert all(s.throttle_volts == 0.0 and s.speed_mps == 0.0 for s in run.samples)


def test_a_stick_pushed_within_the_debounce_drives_by_rc_until_the_move_counts() -> None:
    """The debounce's price, stated: for its frames the source the switch left still drives.
    A move to STOP is never so delayed (row 26)."""
    run = played(found(f"{{ at_s = {MOVE_S + 0.02}, rc = {{ throttle = 0.4 }} }}"))
    assert run.found == set()
    assert any(s.throttle_volts > 0.0 for s in run.after(MOVE_S) if s.time_s < COUNTS_S)
    assert all(_stopped(s) for s in run.after(COUNTS_S + SLACK_S))


def test_the_oracle_before_demanded_the_stop_before_the_move_could_count(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The mistake, kept: CAN's deadline counted from the move itself flags the right robot."""

    def at_once(oracle: HazardOracle, now: float) -> None:
        oracle.stop_event(OracleCause.CAN_LOST, now)

    monkeypatch.setattr(HazardOracle, "switched_to_lost_can", at_once)
    run = played(found())
    assert run.found == {"H1"}
    assert run.first_s["H1"] < COUNTS_S


def test_a_controller_one_frame_slower_than_the_debounce_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The teeth: the deadline counted from the debounce is no wider than the debounce."""
    monkeypatch.setattr(supervisor, "_debounced", one_frame_late())
    run = played(found())
    assert not all(_stopped(s) for s in run.after(COUNTS_S + SLACK_S))
    assert "H1" in run.found


# --- row 78: a second sender during a long debounce, over before the move counts -------------

NINE_FRAMES = parse_config(
    "[timeouts]\nrc_timeout_s = 1.0\nwatchdog_s = 5.0\n\n[supervisor]\ndebounce_frames = 9\n\n"
    "[sim]\nrc_frame_period_s = 0.1\n",
    "nine-frames",
)
TO_CAN_S = 7.945
NINE_COUNTS_S = TO_CAN_S + 9 * FRAME_S  # the last of the debounce's frames


def impostor_during_the_debounce(frames: int) -> str:
    """`bywire verify --config FILE --budget 800 --seed 6`, campaign 184, shrunk (there with 5
    frames): armed in RC, the switch to CAN, and a keyed second sender 5 ms later."""
    return f"""
name = "impostor-during-the-debounce"
duration_s = 10.5
event = [
    {{ at_s = 0.0, rc = {{ gear = "forward" }} }},
    {{ at_s = 0.0, hlc = {{ steering = 0.0, throttle = 0.0, brake = 0.0, gear = "forward" }} }},
    {{ at_s = 4.3, rc = {{ mode = "stop" }} }},
    {{ at_s = 4.36, rc = {{ throttle = 0.0, mode = "rc" }} }},
    {{ at_s = 7.9, hlc = {{ steering = -0.9, throttle = 0.0 }} }},
    {{ at_s = {TO_CAN_S}, rc = {{ mode = "can" }} }},
    {{ at_s = 7.95, fault = "can_impostor", count = {frames}, keyed = true }},
]
"""


def test_a_second_sender_over_before_the_move_counts_stops_nothing() -> None:
    """Five frames (0.1 s) of a second sender while a 0.9 s debounce counts the move to CAN:
    by the time it counts the id is trusted again (a window of good frames), the robot goes on
    in CAN, its drive enabled and the spring brake released throughout. The oracle demanded a
    stop 0.2 s after the second sender began, while the robot was still (rightly) in RC."""
    run = judged(NINE_FRAMES, impostor_during_the_debounce(5))
    assert run.found == set()
    assert all(s.motors_enabled and not s.ebrake_engaged for s in run.after(7.9))
    assert any(s.mode.name == "CAN" for s in run.after(NINE_COUNTS_S + SLACK_S))


def test_a_second_sender_still_distrusted_when_the_move_counts_stops_the_robot_then(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Forty frames (0.8 s): the id is still distrusted when the move counts, and the robot
    stops then (the e-brake on, 0 V). The teeth of the deadline: a debounce one frame slower
    is found (H1), and so is a supervisor for which CAN's causes never latch."""
    run = judged(NINE_FRAMES, impostor_during_the_debounce(40))
    assert run.found == set()
    assert all(_stopped(s) for s in run.after(NINE_COUNTS_S + SLACK_S))
    with monkeypatch.context() as late:
        late.setattr(supervisor, "_debounced", one_frame_late())
        assert "H1" in judged(NINE_FRAMES, impostor_during_the_debounce(40)).found
    can_loss_never_latches(monkeypatch)
    run = judged(NINE_FRAMES, impostor_during_the_debounce(40))
    assert not all(_stopped(s) for s in run.after(NINE_COUNTS_S + SLACK_S))
    assert "H1" in run.found
