"""Issue 29: a stop always gets through, and the stop itself is safe.

Each test replays one finding of the adversarial pass as a sequence on the whole robot (the real
controller on the simulated one, virtual time) and judges it on what the hardware did: the
enable line, the DAC's volts, the e-brake line, the hydraulic duty, the steering pulse and the
vehicle's true speed. Each failed on the controller before the issue (dce19d3), as its docstring
says; the ordinary-operation tests beside them hold what must not change.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from bywire.config import RobotConfig, default_sim_config, parse_config
from bywire.control.stop import StopCategory, StopConfig, StopPhase, StopState, stop_step
from bywire.error_flags import ErrorFlag
from bywire.model import ControlMode
from bywire.sim.runner import SimRun
from bywire.sim.scenario import parse_scenario
from tests.system.harness import volts_at

ARMED_IN_RC = """
[[event]]
at_s = 0.3
rc = { mode = "stop", gear = "forward", throttle = 0.0 }
[[event]]
at_s = 0.5
rc = { mode = "rc" }
"""
DRIVING_BY_RC = (
    ARMED_IN_RC
    + """
[[event]]
at_s = 0.7
rc = { throttle = 0.6 }
"""
)
DRIVING_BY_CAN = """
[[event]]
at_s = 0.0
hlc = { steering = 0.0, throttle = 0.0, brake = 0.0, gear = "forward" }
[[event]]
at_s = 0.3
rc = { mode = "stop", gear = "forward", throttle = 0.0 }
[[event]]
at_s = 0.5
rc = { mode = "can" }
[[event]]
at_s = 0.8
hlc = { throttle = THROTTLE }
"""


def played(
    events: str,
    duration_s: float,
    *,
    robot: RobotConfig | None = None,
    authenticated: bool = False,
    prepare: Callable[[SimRun], None] | None = None,
) -> SimRun:
    """The scenario of `events` played to its end; the run, to read the hardware's history."""
    header = f'name = "t"\ndescription = "t"\nduration_s = {duration_s}\n'
    if authenticated:
        header += "authenticated = true\n"
    scenario = parse_scenario(header + events, "<test>")
    run = SimRun(robot or default_sim_config(), scenario)
    if prepare is not None:
        prepare(run)
    run.run()
    return run


def level(run: SimRun, line: str, at_s: float) -> bool:
    return run.world.gpio[line].level_at(at_s)


def dac_volts(run: SimRun, channel: int, at_s: float) -> float:
    return volts_at(run.world.dac.history, channel, at_s)


def stopping(run: SimRun, at_s: float) -> bool:
    """The hardware stops the robot at `at_s`: e-brake engaged, throttle at 0 V, and the drive
    off or braking by regeneration (a controlled stop)."""
    return (
        not level(run, "ebrake_release", at_s)
        and dac_volts(run, 0, at_s) == 0.0
        and (not level(run, "motors_enable", at_s) or dac_volts(run, 1, at_s) > 0.0)
    )


# --- finding 1: a stop request is filtered like any other input ---------------------------------

STOP_AMONG_A_SECOND_SENDER = (
    DRIVING_BY_RC
    + """
[[event]]
at_s = 1.5
fault = "can_impostor_control"     # an idle teleop joins the bus: the control id is untrusted
count = 200
[[event]]
at_s = 2.0
hlc_control = { remote_stop = true, re_enable = false }
"""
)


@pytest.mark.parametrize("authenticated", [False, True], ids=["plain", "authenticated"])
def test_a_remote_stop_gets_through_a_second_sender_on_the_control_id(
    authenticated: bool,
) -> None:
    # Before: the id was untrusted (without authentication by the counter, with it by the
    # unsigned frames' failures), the whole frame was dropped, stop included: the robot drove
    # on at 3 V to the end.
    run = played(STOP_AMONG_A_SECOND_SENDER, 3.0, authenticated=authenticated)
    assert dac_volts(run, 0, 1.99) > 2.5  # driving by RC, the second sender already on the bus
    deadline_s = 2.0 + 0.020 + 2 * 0.010  # a command period (the frame), two control periods
    assert stopping(run, deadline_s)
    assert all(stopping(run, 2.0 + tick * 0.01) for tick in range(5, 100))
    assert run.runtime.outputs is not None
    assert run.runtime.outputs.mode is ControlMode.STOP


def test_unsigned_frames_cost_the_computers_signed_frames_no_trust() -> None:
    # Before: each unsigned frame was a miss of the id's trust window, so a node without the key
    # made the computer's own movement id untrusted and stopped CAN mode.
    events = (
        DRIVING_BY_CAN.replace("THROTTLE", "0.3")
        + """
[[event]]
at_s = 1.5
fault = "can_impostor"
count = 60
"""
    )
    run = played(events, 3.0, authenticated=True)
    assert run.runtime.can.auth_failures  # every frame of the impostor failed
    assert all(level(run, "motors_enable", 1.5 + tick * 0.05) for tick in range(30))
    assert all(level(run, "ebrake_release", 1.5 + tick * 0.05) for tick in range(30))
    assert run.record.error_flags_seen & ErrorFlag.CAN_AUTH_FAILED


def test_a_remote_stop_held_by_every_frame_arrives_once_so_rc_may_still_take_over() -> None:
    # Ordinary operation: a stop that passes the filters must not lock the RC operator out.
    events = (
        STOP_AMONG_A_SECOND_SENDER
        + """
[[event]]
at_s = 2.3
rc = { mode = "stop", throttle = 0.0 }
[[event]]
at_s = 2.5
rc = { mode = "rc" }
[[event]]
at_s = 2.6
rc = { throttle = 0.4 }
"""
    )
    run = played(events, 3.5)
    assert level(run, "motors_enable", 3.4)
    assert level(run, "ebrake_release", 3.4)
    assert dac_volts(run, 0, 3.4) > 0.5


# --- finding 2: timing is trusted, not supervised ---------------------------------------------

SLOW_DAC = (
    DRIVING_BY_RC
    + """
[[event]]
at_s = 2.0
fault = "dac_slow"
stall_s = TRANSFER_S
[[event]]
at_s = 2.5
rc = { mode = "stop" }
"""
)


def slow_dac(transfer_s: float) -> str:
    return SLOW_DAC.replace("TRANSFER_S", str(transfer_s))


def test_a_dac_whose_every_transfer_crawls_stops_the_robot_as_the_first_one_returns() -> None:
    # Before: 80 ms transfers that succeed made 160 ms passes, the watchdog (fed every pass) never
    # tripped, and the operator's STOP at 2.5 s cut the enable line 120 ms and engaged the
    # e-brake 280 ms later.
    run = played(slow_dac(0.08), 3.5)
    assert level(run, "motors_enable", 1.99)
    first_returns_s = 2.0 + 0.010 + 0.08  # the next driving period's transfer, and its crawl
    assert not level(run, "motors_enable", first_returns_s + 0.001)
    assert not level(run, "ebrake_release", first_returns_s + 0.010)
    assert run.world.pwm.hydrobrake.pulse_at(first_returns_s + 0.010) > 0.0
    outputs = run.runtime.outputs
    assert outputs is not None
    assert {"DAC_FAULT", "TIMING"} <= {c.name for c in outputs.causes}
    assert run.record.error_flags_seen & ErrorFlag.TIMING_FAULT


def test_a_loop_that_keeps_feeding_the_watchdog_but_misses_its_deadlines_trips_it() -> None:
    # Before: the watchdog judged only the gap between feeds, and a pass every 160 ms fed it.
    run = played(slow_dac(0.08), 3.5)
    watchdog = run.runtime.watchdog
    assert watchdog is not None
    assert watchdog.trips >= 1


def test_two_millisecond_transfers_are_ordinary_and_never_stop_the_robot() -> None:
    events = (
        DRIVING_BY_RC
        + """
[[event]]
at_s = 1.0
fault = "dac_slow"
stall_s = 0.002
"""
    )
    run = played(events, 3.0)
    assert all(level(run, "motors_enable", 1.0 + tick * 0.05) for tick in range(40))
    assert run.runtime.outputs is not None
    assert run.runtime.outputs.mode is ControlMode.RC
    assert not run.record.error_flags_seen & ErrorFlag.TIMING_FAULT


def test_a_pass_writes_the_brakes_and_the_enable_line_before_the_slow_dac() -> None:
    # Before: the driving task's I2C writes ran before the brake task's, so a STOP's e-brake
    # waited for the DAC's transfers.
    run = played(slow_dac(0.003), 3.0)  # slow, but within its budget (3.5 ms)
    ebrake_at_s = next(
        t for t, up in run.world.gpio["ebrake_release"].history if t > 2.5 and not up
    )
    dac_at_s = next(t for t, channel, _ in run.world.dac.history if t > 2.5 and channel == 0)
    assert ebrake_at_s < dac_at_s  # the same pass: the e-brake first, the transfer after


# --- finding 3: STOP threw away the drive's own braking -----------------------------------------

BRAKES_FAIL_AT_SPEED = (
    ARMED_IN_RC
    + """
[[event]]
at_s = 0.7
rc = { throttle = 0.8 }
[[event]]
at_s = 1.0
fault = "ebrake_fail"              # latent: the hazard table says it cannot be detected
[[event]]
at_s = 3.6
fault = "hydrobrake_fail"
[[event]]
at_s = 3.6
rc = { throttle = -1.0 }           # the operator pulls full brake
"""
)


def test_a_stop_for_a_failed_hydraulic_brake_keeps_the_drives_regenerative_brake() -> None:
    # Before: the pressure monitor's STOP dropped the enable line at 1.5 m/s, switching off
    # regeneration, the only brake left: standstill after 14 s and 7.9 m.
    samples: list[tuple[float, float, float]] = []

    def watch(run: SimRun) -> None:
        state = run.world.vehicle
        run.runtime.on_cycle.append(
            lambda now: samples.append((now, state.state.speed_mps, state.state.distance_m))
        )

    run = played(BRAKES_FAIL_AT_SPEED, 7.0, prepare=watch)
    at_fault = next((t, v, d) for t, v, d in samples if t >= 3.6)
    assert at_fault[1] > 1.3  # rolling fast when the brakes go
    stopped = next(((t, d) for t, v, d in samples if t > 3.6 and v == 0.0), None)
    assert stopped is not None, "never stood still"
    assert stopped[0] - 3.6 < 2.0  # regeneration alone: about 1 s from 1.5 m/s
    assert stopped[1] - at_fault[2] < 2.0
    outputs = run.runtime.outputs
    assert outputs is not None
    assert "HYDRO_PRESSURE" in {c.name for c in outputs.causes}
    assert not level(run, "motors_enable", 6.9)  # power off once it stood still


# Found by `bywire verify --budget 2000 --seed 0` (campaign 1398, H7): the spring brake fails
# unnoticed, the hydraulic brake fails as the operator brakes, and the wheel sensor dies at
# 0.16 m/s, inside the speed check's blind spot, so its 0 reads as a stop that stood still.
BRAKES_AND_SENSOR_FAIL_SLOWING = """
[[event]]
at_s = 0.2
rc = { mode = "stop", gear = "forward", throttle = 0.0 }
[[event]]
at_s = 0.26
rc = { mode = "rc" }
[[event]]
at_s = 0.3
rc = { throttle = 0.8 }
[[event]]
at_s = 1.43
fault = "ebrake_fail"
[[event]]
at_s = 1.73
fault = "hydrobrake_fail"
[[event]]
at_s = 1.73
rc = { throttle = -1.0 }
[[event]]
at_s = 1.93
fault = "wheel_sensor_dead"
"""


def test_a_wheel_sensor_dying_slowly_does_not_end_the_only_brake_left() -> None:
    # Before: the dead sensor's 0 m/s ended the controlled stop at once (power off at 2.04 s)
    # with both mechanical brakes failed: the robot rolled on at 0.15 m/s on rolling drag alone.
    samples: list[tuple[float, float, bool]] = []

    def watch(run: SimRun) -> None:
        state = run.world.vehicle
        run.runtime.on_cycle.append(
            lambda now: samples.append(
                (now, state.state.speed_mps, level(run, "motors_enable", now))
            )
        )

    played(BRAKES_AND_SENSOR_FAIL_SLOWING, 3.0, prepare=watch)
    moving_at_death = next(v for t, v, _ in samples if t >= 1.93)
    assert moving_at_death > 0.1  # rolling, inside the blind spot, when the sensor dies
    stood = next((t for t, v, _ in samples if t > 1.93 and v == 0.0), None)
    assert stood is not None, "still rolling at the end"
    assert stood < 2.5
    enabled_until = max(t for t, _, on in samples if on)
    assert enabled_until >= stood  # regeneration kept until the robot truly stood
    assert not samples[-1][2]  # and then power off


def test_a_controlled_stop_that_does_not_slow_the_robot_removes_power() -> None:
    # Category 1 keeps the drive powered only while it brakes: a drive that keeps pushing (here
    # a throttle line the DAC holds high: the regenerative brake cannot win) is switched off.
    config = StopConfig(controlled_max_s=2.5, controlled_min_decel_mps2=0.5, standstill_mps=0.05)
    state, phases = StopState(), []
    for tick in range(100):
        now = tick * 0.01
        state, phase = stop_step(
            state,
            stopping=True,
            category=StopCategory.CONTROLLED,
            powered=True,
            speed_mps=1.5,  # not slowing at all
            now=now,
            config=config,
            standstill_proven_s=None,
        )
        phases.append(phase)
    assert phases[0] is StopPhase.BRAKING
    assert phases[-1] is StopPhase.POWER_OFF
    assert state.escalated
    assert phases.index(StopPhase.POWER_OFF) * 0.01 < 0.3 + 0.15 / 0.5 + 0.02


# --- finding 5: a lamp message stopped the robot ----------------------------------------------


def test_a_second_sender_on_the_lights_id_affects_the_lights_alone() -> None:
    # Before: the lights' id untrusted made CAN untrusted: CAN driving stopped, e-brake engaged.
    events = (
        DRIVING_BY_CAN.replace("THROTTLE", "0.4")
        + """
[[event]]
at_s = 0.0
hlc_lights = { low_beam = true }
[[event]]
at_s = 1.5
fault = "can_impostor_lights"
count = 100
"""
    )
    run = played(events, 6.0)
    assert all(level(run, "motors_enable", 1.5 + tick * 0.05) for tick in range(80))
    assert all(level(run, "ebrake_release", 1.5 + tick * 0.05) for tick in range(80))
    assert run.record.error_flags_seen & ErrorFlag.LIGHTS_UNTRUSTED
    assert not run.record.error_flags_seen & ErrorFlag.CAN_UNTRUSTED
    # once the second sender is gone and its id trusted again, the computer's lights rule
    assert level(run, "low_beam", 5.9)


# --- finding 6: a watchdog trip froze the boosted steering pulse -------------------------------


def test_a_watchdog_trip_holds_the_commanded_steering_not_the_boosted_pulse() -> None:
    # Before: the trip left the servo on the boosted pulse (0.88 of full lock for 0.4 asked).
    robot = parse_config('backend = "sim"\n\n[steering]\nboost_gain = 1.0\n', "<boosted>")
    events = (
        ARMED_IN_RC
        + """
[[event]]
at_s = 1.0
rc = { steering = 0.4 }
[[event]]
at_s = 1.11
fault = "dac_stall"                # hangs the loop past the watchdog while the servo lags
stall_s = 0.4
"""
    )
    run = played(events, 2.0, robot=robot)
    watchdog = run.runtime.watchdog
    assert watchdog is not None
    assert watchdog.trips == 1
    servo = robot.steering.servo
    commanded_s = servo.center_pulse_s + 0.4 * (servo.max_pulse_s - servo.center_pulse_s)
    boosted_s = run.world.pwm.steering.pulse_at(1.115)
    assert boosted_s > commanded_s + 1e-5  # the servo lags: the boost pushes past 0.4
    held_s = run.world.pwm.steering.pulse_at(1.11 + 0.3)  # tripped, the write still hung
    assert held_s == pytest.approx(commanded_s, abs=1e-7)
