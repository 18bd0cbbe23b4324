"""Issue 41 finding 4: budgets come from deadlines. Slow DAC transfers that each keep their
budget must not make a stop later than `docs/SAFETY.md` promises: the operator's STOP reaches
the spring brake within the IBUS frame that carries it plus one control period (17.7 ms), and an
RC loss within its timeout plus 20 ms. Judged on the simulated hardware alone: when the
e-brake's line drops and the throttle reaches 0 V, against the switch's move or the unplug.

The promised figures are SAFETY's own (the frame period, one control period; the input-loss
deadline's 20 ms), written out here so the tests judge the code that states them
(`bywire.config.deadlines.STOP_PROMISES`) rather than repeat it."""

from __future__ import annotations

import pytest

from bywire.config import RobotConfig, default_sim_config, parse_config
from bywire.errors import ConfigError
from bywire.protocol import ibus
from bywire.sim.runner import SimRun
from tests.system.test_stop_gets_through import DRIVING_BY_RC, dac_volts, level, played

CONTROL_PERIOD_S = 0.010  # docs/SAFETY.md: "plus one control period (10 ms)"
INPUT_LOSS_S = 0.020  # docs/SAFETY.md row 45: "a lost input is acted on within its timeout + 20 ms"
OPERATOR_STOP_S = ibus.FRAME_PERIOD_S + CONTROL_PERIOD_S  # 17.7 ms
IBUS_WIRE_S = ibus.FRAME_LENGTH * 10 / ibus.BAUD_RATE  # a frame on the wire, 8N1
SLOW_FROM_S = 2.0
PHASES = 24  # the switch's move swept across a frame period and a slow pass, 0.9 ms apart
PHASE_STEP_S = 0.0009


def _slow_then(transfer_s: float, at_s: float, event: str) -> str:
    return (
        DRIVING_BY_RC
        + f"""
[[event]]
at_s = {SLOW_FROM_S}
fault = "dac_slow"
stall_s = {transfer_s}
[[event]]
at_s = {at_s}
{event}
"""
    )


def _ebrake_engaged_at(run: SimRun, after_s: float) -> float:
    """When the e-brake's line was low from `after_s` on (`after_s` itself if it already was)."""
    if not level(run, "ebrake_release", after_s):
        return after_s
    return next(t for t, up in run.world.gpio["ebrake_release"].history if t >= after_s and not up)


def _throttle_zero_at(run: SimRun, after_s: float) -> float:
    if dac_volts(run, 0, after_s) == 0.0:
        return after_s
    return next(
        t
        for t, channel, volts in run.world.dac.history
        if t >= after_s and channel == 0 and volts == 0.0
    )


def _worst_operator_stop(
    robot: RobotConfig, transfer_s: float, *, driving_until_stop: bool = True
) -> tuple[float, float]:
    """The latest the e-brake's line dropped, and the throttle reached 0 V, after the switch
    moved to STOP, over the phases (0 where a fault had stopped the robot before)."""
    worst_brake_s = worst_throttle_s = 0.0
    for phase in range(PHASES):
        stop_s = 2.5 + phase * PHASE_STEP_S
        run = played(_slow_then(transfer_s, stop_s, 'rc = { mode = "stop" }'), 2.7, robot=robot)
        if driving_until_stop:  # transfers within their budget are no fault
            assert level(run, "ebrake_release", stop_s - 0.001)
            assert dac_volts(run, 0, stop_s - 0.001) > 0.5
        worst_brake_s = max(worst_brake_s, _ebrake_engaged_at(run, stop_s) - stop_s)
        worst_throttle_s = max(worst_throttle_s, _throttle_zero_at(run, stop_s) - stop_s)
    return worst_brake_s, worst_throttle_s


def _worst_rc_loss(robot: RobotConfig, transfer_s: float) -> float:
    """The latest the e-brake's line dropped after the receiver was unplugged, less the wire
    time of a frame that was already on its way (the timeout counts from the last frame)."""
    worst_s = 0.0
    for phase in range(PHASES // 2):
        lost_s = 2.5 + phase * 2 * PHASE_STEP_S
        run = played(_slow_then(transfer_s, lost_s, 'fault = "rc_link_lost"'), 2.8, robot=robot)
        assert level(run, "ebrake_release", lost_s + 0.05)  # driving until the timeout
        worst_s = max(worst_s, _ebrake_engaged_at(run, lost_s) - lost_s - IBUS_WIRE_S)
    return worst_s


@pytest.mark.parametrize("transfer", ["just under the budget", "9.9 ms"])
def test_slow_transfers_within_their_budget_keep_the_operators_stop_promise(
    transfer: str,
) -> None:
    # Before: on the default robot, transfers of 9.9 ms (under the 10 ms budget) made passes of
    # 19.8 ms (under 20 ms) and the operator's STOP reached the spring brake 28 ms after the
    # switch moved, against the 17.7 ms promised; no fault.
    # Now the default budgets are what the promise leaves: transfers just under theirs keep it,
    # and 9.9 ms ones are a failing DAC (category 0) that has stopped the robot by then or
    # stops it within the promise.
    robot = default_sim_config()
    budget_s = robot.timeouts.dac_transfer_budget_s
    within = transfer == "just under the budget"
    transfer_s = 0.99 * budget_s if within else 0.0099
    worst_brake_s, worst_throttle_s = _worst_operator_stop(
        robot, transfer_s, driving_until_stop=within
    )
    assert worst_brake_s <= OPERATOR_STOP_S + 1e-9
    # The throttle's 0 V is the drive's next transfer after the brakes: one budget later.
    assert worst_throttle_s <= OPERATOR_STOP_S + budget_s + 1e-9


LOOSE_BUDGETS = (
    "[timeouts]\npass_budget_s = 0.05\nwrite_budget_s = 0.02\ndac_transfer_budget_s = 0.02"
)
LOOSEST_LEGAL = (
    "[timeouts]\npass_budget_s = 0.0072\nwrite_budget_s = 0.0072\ndac_transfer_budget_s = 0.0036"
)


SLOWEST_TICK = (  # the slowest tasks the input-loss deadline allows, and what they then ask
    "\n[tasks]\nhydrobrake_rate_hz = 50.0\nsteering_rate_hz = 50.0\ndriving_rate_hz = 50.0"
    "\n[interlocks]\nspeed_step_tolerance_mps = 0.2\n"
)


def _loosest_accepted() -> RobotConfig:
    """The issue's loose file where the loader takes it, else the loosest budgets the promises
    leave (its refusal is `tests/config/test_deadlines.py`'s)."""
    try:
        return parse_config(LOOSE_BUDGETS, "<loose>")
    except ConfigError:
        return parse_config(LOOSEST_LEGAL, "<loosest legal>")


def test_the_loosest_budgets_the_loader_accepts_keep_every_stop_promise() -> None:
    # Before: budgets of 50 ms a pass and 20 ms a transfer were legal; with 19 ms transfers the
    # operator's STOP took 41 ms and an RC loss 128 ms (its timeout + 28 ms), no fault. Now the
    # file is refused, and the loosest legal budgets, with every transfer just under its own,
    # keep the promises.
    robot = _loosest_accepted()
    transfer_s = 0.95 * robot.timeouts.dac_transfer_budget_s
    worst_brake_s, _ = _worst_operator_stop(robot, transfer_s)
    assert worst_brake_s <= OPERATOR_STOP_S + 1e-9
    rc_loss_s = _worst_rc_loss(robot, transfer_s)
    assert rc_loss_s <= robot.timeouts.rc_timeout_s + INPUT_LOSS_S + 1e-9
    # The slowest tick the input-loss deadline allows (50 Hz), with the same transfers.
    slow_tick = parse_config(LOOSEST_LEGAL + SLOWEST_TICK, "<loosest legal, 50 Hz>")
    assert _worst_rc_loss(slow_tick, transfer_s) <= robot.timeouts.rc_timeout_s + INPUT_LOSS_S
