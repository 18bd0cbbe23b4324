"""A mode switch that moves faster than its frames, on a legal 10 Hz receiver (the robot file of
row 74: `sim.rc_frame_period_s = 0.1`). `bywire verify --config FILE --budget 400 --seed 4`
found two oracle mistakes there, the controller right both times (docs/SAFETY.md rows 76, 77),
judged here on the hardware and by the oracle, each with the oracle's teeth kept."""

from __future__ import annotations

import pytest

from bywire.config import parse_config
from bywire.control import supervisor
from bywire.model import ControlMode
from tests.sim.verify.mutants import readied_by_one_frame
from tests.system.judged import Judged, judged

SLOW_FRAMES = parse_config(
    "[timeouts]\nrc_timeout_s = 1.0\nwatchdog_s = 5.0\n\n[sim]\nrc_frame_period_s = 0.1\n",
    "slow-frames",
)


def played(scenario: str) -> Judged:
    return judged(SLOW_FRAMES, scenario)


def scenario(computer: str, *events: str, duration_s: float = 4.2) -> str:
    joined = ",\n    ".join(
        [
            '{ at_s = 0.0, rc = { gear = "forward" } }',
            '{ at_s = 0.0, hlc = { throttle = 0.0, brake = 0.0, gear = "forward" } }',
            '{ at_s = 0.2, rc = { mode = "stop" } }',
            *events,
        ]
    )
    return f'name = "glimpses"\n{computer}duration_s = {duration_s}\nevent = [\n    {joined},\n]\n'


# --- row 76: back to CAN through two glimpses of STOP and one frame of RC --------------------

CAN_DRIVING = {
    "the bridge": (
        'computer = "bridge"\n',
        "{ at_s = 0.26, hlc = { throttle = 0.0 } }",
        '{ at_s = 0.26, rc = { mode = "can" } }',
        "{ at_s = 0.35, bridge_service = { enable = true } }",
        "{ at_s = 0.45, planner = { speed_mps = 0.5 } }",
        "{ at_s = 0.45, planner = { publishing = true } }",
    ),
    "a computer": (  # armed by a stay at STOP (the bridge arms with a re-enable)
        "",
        "{ at_s = 0.6, hlc = { throttle = 0.0 } }",
        '{ at_s = 0.6, rc = { mode = "can" } }',
        "{ at_s = 1.0, hlc = { throttle = 0.3 } }",
    ),
}


FOUND_MOVES = ((3.22, "stop"), (3.28, "rc"), (3.32, "stop"), (3.38, "can"))
"""Campaign 231, shrunk: STOP for 60 ms, RC for 40 ms, STOP for 60 ms, back to CAN; at 10 Hz
no frame shows either STOP, and one frame shows RC."""
AFTER_A_STAY = ((3.2, "stop"), (3.45, "rc"), (3.48, "stop"), (3.5, "can"))
"""Three frames show STOP (3.2028, 3.3028, 3.4028 s: a stay), none the RC or the second STOP,
and the switch is back at CAN 0.3 s after it left, within the debounce's 0.322 s."""


def back_to_can(computer: str, moves: tuple[tuple[float, str], ...]) -> str:
    header, *driving = CAN_DRIVING[computer]
    switch = (f'{{ at_s = {at_s}, rc = {{ mode = "{mode}" }} }}' for at_s, mode in moves)
    return scenario(header, *driving, *switch)


@pytest.mark.parametrize("computer", CAN_DRIVING.keys())
def test_back_to_can_through_glimpses_no_frame_showed_is_no_new_handover(computer: str) -> None:
    """One frame of RC is no move (the debounce's three): the robot drove on in CAN by the
    computer's throttle, never braking. The oracle took the return for a new handover into
    CAN, whose throttle had not been zero since, and flagged H2 (with the bridge, as found)."""
    run = played(back_to_can(computer, FOUND_MOVES))
    assert run.found == set()
    window = run.after(3.2)
    assert all(s.mode is ControlMode.CAN and not s.ebrake_engaged for s in window)
    assert min(s.throttle_volts for s in window) > 0.0


def test_a_return_to_can_after_a_stay_at_stop_still_needs_zero_throttle(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The teeth: after a stay at STOP that frames showed, the return to CAN is an arming,
    even within the debounce of leaving CAN and through a STOP no frame showed; the
    computer's throttle (still 0.3) refuses it. A supervisor that takes any throttle for zero
    arms with it, and is found (H2: CAN never seen at zero throttle)."""
    run = played(back_to_can("a computer", AFTER_A_STAY))
    assert run.found == set()
    assert all(s.throttle_volts == 0.0 for s in run.after(3.5))  # refused
    monkeypatch.setattr(supervisor.SupervisorInputs, "throttle_zero", lambda _self, _t: True)
    run = played(back_to_can("a computer", AFTER_A_STAY))
    assert any(s.throttle_volts > 0.0 for s in run.after(3.8))
    assert "H2" in run.found


# --- row 77: a bouncing switch's frames at STOP around an operator's flick through STOP -------

RC_ARMED = ('{ at_s = 0.26, rc = { throttle = 0.0, mode = "rc" } }',)
FLICK = (
    '{ at_s = 2.38, rc = { mode = "stop" } }',
    '{ at_s = 2.44, rc = { throttle = 0.0, mode = "rc" } }',
)
BOUNCING = {  # campaign 139 shrunk two ways: a flick through STOP while the switch bounces…
    "from RC": scenario(
        "", *RC_ARMED, '{ at_s = 1.41, fault = "switch_chatter", count = 11 }', *FLICK
    ),
    # …and the same flick from between STOP and RC, where a bounce reads the STOP position
    "from the gap": scenario(
        "",
        *RC_ARMED,
        '{ at_s = 1.41, fault = "switch_chatter", count = 11 }',
        "{ at_s = 2.18, rc = { mode_raw = 1250 } }",
        *FLICK,
    ),
}


def _armed_from(run: Judged, from_s: float) -> bool:
    return all(s.motors_enabled and not s.ebrake_engaged for s in run.after(from_s))


@pytest.mark.parametrize("events", BOUNCING.values(), ids=BOUNCING.keys())
def test_a_bounce_at_stop_on_either_side_of_a_flick_can_complete_the_stay(events: str) -> None:
    """The bounce's frames at STOP just before and just after the operator's 60 ms flick make
    three in a row with the one the flick showed: a stay at STOP, and the move back to RC at
    zero throttle armed (the operator's own re-arming gesture). The oracle counted the stay
    from a frame before the flick only, or from the flick itself out of the gap, and flagged
    the arming (H1)."""
    run = played(events)
    assert run.found == set()
    assert _armed_from(run, 2.85)


def test_a_flick_after_the_bounce_is_over_arms_nothing_and_an_arming_on_it_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The teeth: once the bounce is over (4 frames), the same flick shows one frame at STOP
    and arms nothing; a supervisor that takes one frame for a stay arms, and is found (H1)."""
    over = scenario("", *RC_ARMED, '{ at_s = 1.41, fault = "switch_chatter", count = 4 }', *FLICK)
    run = played(over)
    assert run.found == set()
    assert not _armed_from(run, 2.85)
    monkeypatch.setattr(supervisor, "_from_stop", readied_by_one_frame())
    run = played(over)
    assert _armed_from(run, 2.85)
    assert "H1" in run.found
