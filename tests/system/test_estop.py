"""Issue 44: the E-stop on the whole robot (the real controller on the simulated one, virtual
time), judged on what the hardware did: the enable line, the e-brake's release line and the
throttle DAC's volts.

A press, a broken wire and a press that bounces each end in power off within one control period
plus the debounce (10 + 20 ms), latched; a release alone does not re-enable, a release and the
operator's switch through STOP does. A dead line (it reads low from power-up) is a press.
"""

from __future__ import annotations

import pytest

from bywire.config import RobotConfig, default_sim_config, parse_config
from bywire.control.estop import BOUNCE_S
from bywire.error_flags import ErrorFlag
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario
from tests.system.harness import volts_at

PERIOD_S = 0.010
BOUND_S = PERIOD_S + BOUNCE_S  # the promise: one control period plus the debounce
FAULT_AT_S = 1.503  # between two ticks: the worst place for a sampled input
RELEASE_AT_S = 2.0
END_S = 3.0

DRIVING_BY_RC = """
[[event]]
at_s = 0.3
rc = { mode = "stop", gear = "forward", throttle = 0.0 }
[[event]]
at_s = 0.5
rc = { mode = "rc" }
[[event]]
at_s = 0.7
rc = { throttle = 0.6 }
"""

FAULTS = {
    "press": ("estop = { pressed = true }", "estop = { pressed = false }"),
    "broken wire": ('fault = "estop_wire_break"', 'fault = "estop_wire_mend"'),
    "chatter": ('fault = "estop_chatter"\ncount = 9', "estop = { pressed = false }"),
}


def played(events: str, duration_s: float, robot: RobotConfig | None = None) -> SimRun:
    header = f'name = "t"\ndescription = "t"\nduration_s = {duration_s}\n'
    run = SimRun(robot or default_sim_config(), parse_scenario(header + events, "<test>"))
    run.run()
    return run


def _event(at_s: float, action: str) -> str:
    return f"[[event]]\nat_s = {at_s}\n{action}\n"


def powered(run: SimRun, at_s: float) -> bool:
    """The hardware drives at `at_s`: the enable line high or the e-brake released or volts on
    the throttle (any one of them is no category-0 stop)."""
    gpio = run.world.gpio
    return (
        gpio["motors_enable"].level_at(at_s)
        or gpio["ebrake_release"].level_at(at_s)
        or volts_at(run.world.dac.history, 0, at_s) > 0.0
    )


def ticks(from_s: float, to_s: float) -> list[float]:
    return [from_s + n * 0.001 for n in range(round((to_s - from_s) / 0.001))]


@pytest.mark.parametrize("fault", list(FAULTS))
def test_a_press_a_broken_wire_and_chatter_power_off_within_the_bound_latched(fault: str) -> None:
    begin, end = FAULTS[fault]
    run = played(DRIVING_BY_RC + _event(FAULT_AT_S, begin) + _event(RELEASE_AT_S, end), END_S)
    assert powered(run, FAULT_AT_S - 0.001)  # driving when it happens
    assert volts_at(run.world.dac.history, 0, FAULT_AT_S - 0.001) > 2.0
    # power off, spring brake, 0 V within one period + the debounce, and so to the end: the
    # release (at 2.0 s) alone, with the switch still at RC, re-enables nothing
    assert not any(powered(run, at_s) for at_s in ticks(FAULT_AT_S + BOUND_S, END_S))
    outputs = run.runtime.outputs
    assert outputs is not None
    assert outputs.error_flags & ErrorFlag.ESTOP_PRESSED


def test_release_and_the_switch_through_stop_drive_again() -> None:
    events = (
        DRIVING_BY_RC
        + _event(FAULT_AT_S, "estop = { pressed = true }")
        + _event(RELEASE_AT_S, "estop = { pressed = false }")
        + _event(2.3, 'rc = { mode = "stop", throttle = 0.0 }')
        + _event(2.6, 'rc = { mode = "rc" }')
        + _event(2.8, "rc = { throttle = 0.6 }")
    )
    run = played(events, 3.5)
    assert not any(powered(run, at_s) for at_s in ticks(FAULT_AT_S + BOUND_S, 2.6))
    assert powered(run, 3.4)
    assert volts_at(run.world.dac.history, 0, 3.4) > 2.0


def test_the_switch_through_stop_while_still_pressed_clears_nothing() -> None:
    events = (
        DRIVING_BY_RC
        + _event(FAULT_AT_S, "estop = { pressed = true }")
        + _event(2.0, 'rc = { mode = "stop", throttle = 0.0 }')
        + _event(2.4, 'rc = { mode = "rc" }')
    )
    run = played(events, 3.0)
    assert not any(powered(run, at_s) for at_s in ticks(FAULT_AT_S + BOUND_S, 3.0))


def test_a_press_shorter_than_a_control_period_still_latches() -> None:
    events = (
        DRIVING_BY_RC
        + _event(FAULT_AT_S, "estop = { pressed = true }")
        + _event(FAULT_AT_S + 0.002, "estop = { pressed = false }")  # 2 ms, between two ticks
    )
    run = played(events, END_S)
    assert not any(powered(run, at_s) for at_s in ticks(FAULT_AT_S + BOUND_S, END_S))


def test_a_dead_line_is_a_press_and_the_robot_never_arms() -> None:
    """The wiring rule: a line that reads low from power-up (the receiver unpowered, the
    connector off) is a pressed E-stop: the operator's arming is refused."""
    run = SimRun(
        default_sim_config(),
        parse_scenario('name = "t"\ndescription = "t"\nduration_s = 2.0\n' + DRIVING_BY_RC, "<t>"),
    )
    run.world.estop.break_wire()
    run.run()
    assert not any(powered(run, at_s) for at_s in ticks(0.0, 2.0))


def test_without_an_estop_wired_the_button_does_nothing() -> None:
    robot = parse_config('[estop]\nline = "none"\n')
    run = played(DRIVING_BY_RC + _event(FAULT_AT_S, "estop = { pressed = true }"), END_S, robot)
    assert run.world.estop.reads == 0
    assert powered(run, END_S - 0.01)


def test_a_press_during_a_controlled_stop_cuts_the_power_it_kept() -> None:
    """A double fault: the RC link lost at 2.5 s (category 1 from 2.6 s: the drive stays
    powered to brake until the robot stands, 2.66 s on this run), then the E-stop pressed at
    2.603 s while it brakes: power off within the bound (2.633 s), not at the stop's end."""
    events = (
        DRIVING_BY_RC
        + _event(2.5, 'fault = "rc_link_lost"')
        + _event(2.603, "estop = { pressed = true }")
    )
    run = played(events, 3.5)
    enable = run.world.gpio["motors_enable"]
    assert not run.world.gpio["ebrake_release"].level_at(2.602)  # the controlled stop began
    assert enable.level_at(2.602)  # and brakes with the drive powered
    assert not any(powered(run, at_s) for at_s in ticks(2.603 + BOUND_S, 3.5))
