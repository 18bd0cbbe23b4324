"""A scenario played in real time on `KernelRobot`, judged by the simulator's own conditions.

The scenario's `rc`, `hlc`, `hlc_lights` and `hlc_control` actions go to the transmitter and the
computer at their times, applied by the senders' own process (`robot.Senders`: each event's label is
judged from when it was applied); the robot's outputs are read back from the kernel every few tens
of milliseconds and each expectation is judged on those readings with `bywire.sim.conditions`
(`at_s`: the first reading from then on; `within_s`: some reading within the window after the
labelled event; `during_s`: every reading in it). Speed cannot be measured here (no vehicle behind
the motor controllers): conditions on it are left out, and listed as such, and so are expectations
the caller names as not applicable, with the reason.

A `within_s` window gets `GUEST_ALLOWANCE_S` more: the guest is one host CPU shared by bywire,
the rig's senders and the readings, every system call a round trip through ptrace. The readings
are an observer: the senders run above bywire's real-time priority (other machines, on the
robot), bywire above the readings, so on a saturated guest (on a slower or loaded host) only the
readings wait, for 0.5 s at times. A window's end that fell in such a wait is judged on the
first reading after it (the outputs were not looked at when they were due). The deadlines are
the simulator's to judge (and bench/'s to measure on real time); here the outputs must reach
their state, through the kernel's devices, and stay there.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

from bywire.sim.conditions import conditions_hold
from bywire.sim.observe import Observation
from bywire.sim.scenario import Expectation, Scenario
from tests.kernel.robot import KernelRobot

UNMEASURABLE = ("speed_min_mps", "speed_max_mps", "steering_held_since_s")
READ_PERIOD_S = 0.04  # each reading is ~20 sysfs reads, each a round trip through the host
GUEST_ALLOWANCE_S = 0.25
STALL_S = 0.1  # a gap between readings this long: the guest did not run the player


@dataclass
class Played:
    """What a played scenario showed: every reading, the events' times, and the verdicts."""

    readings: list[Observation] = field(default_factory=list)
    labels: dict[str, float] = field(default_factory=dict)
    failed: list[str] = field(default_factory=list)
    passed: list[str] = field(default_factory=list)
    left_out: list[str] = field(default_factory=list)
    started_monotonic_s: float = 0.0  # time.monotonic() at the scenario's 0 s


def play(
    robot: KernelRobot, scenario: Scenario, not_applicable: dict[str, str] | None = None
) -> Played:
    played = Played()
    events = sorted(scenario.events, key=lambda event: event.at_s)
    for event in events:
        if event.kind != "rc" and not event.kind.startswith("hlc"):
            raise ValueError(f"{scenario.name}: a {event.kind} event cannot be played here")
    actions = [{"at_s": e.at_s, "kind": e.kind, "values": dict(e.values)} for e in events]
    started_s = played.started_monotonic_s = time.monotonic()
    robot.senders.play(started_s, actions)
    while (now_s := time.monotonic() - started_s) < scenario.duration_s:
        played.readings.append(robot.observe(now_s))
        time.sleep(READ_PERIOD_S)
    applied = robot.senders.applied()
    for index, event in enumerate(events):
        if event.label is not None and index in applied:
            played.labels[event.label] = applied[index] - started_s
    unplayed = [f"{e.at_s} s {e.kind}" for i, e in enumerate(events) if i not in applied]
    played.failed += [f"the rig did not apply its action at {what}" for what in unplayed]
    for expectation in scenario.expectations:
        reason = (not_applicable or {}).get(expectation.describe())
        if reason is not None:
            played.left_out.append(f"{expectation.describe()}: {reason}")
        else:
            _judge(expectation, played)
    return played


def _judge(expectation: Expectation, played: Played) -> None:
    name = expectation.describe()
    conditions = {k: v for k, v in expectation.conditions.items() if k not in UNMEASURABLE}
    dropped = sorted(set(expectation.conditions) - set(conditions))
    if dropped:
        played.left_out.append(f"{name}: {', '.join(dropped)}")
    if not conditions:
        return
    readings = _window(expectation, played)
    if not readings:
        played.failed.append(f"{name}: no reading in its window")
        return
    if expectation.at_s is not None:
        held = conditions_hold(readings[0], conditions)
    elif expectation.during_s is not None:
        held = all(conditions_hold(reading, conditions) for reading in readings)
    else:
        held = any(conditions_hold(reading, conditions) for reading in readings)
    (played.passed if held else played.failed).append(
        name if held else f"{name}: {_shown(readings[-1], conditions)}"
    )


def _window(expectation: Expectation, played: Played) -> list[Observation]:
    if expectation.at_s is not None:
        return [r for r in played.readings if r.time_s >= expectation.at_s][:1]
    start_s = played.labels.get(str(expectation.after))
    if start_s is None:
        return []
    if expectation.during_s is not None:
        end_s = start_s + expectation.during_s
        return [r for r in played.readings if start_s <= r.time_s <= end_s]
    end_s = start_s + (expectation.within_s or 0.0) + GUEST_ALLOWANCE_S
    inside = [r for r in played.readings if start_s <= r.time_s <= end_s]
    return inside + _first_look_after(played.readings, end_s)


def _first_look_after(readings: list[Observation], end_s: float) -> list[Observation]:
    """The first reading after `end_s` when the player did not run at `end_s` (no reading for
    more than STALL_S across it): what the outputs did by then was not seen, and the first look
    after it stands in for the one that was due."""
    for before, after in itertools.pairwise(readings):
        if before.time_s <= end_s < after.time_s:
            return [after] if after.time_s - before.time_s > STALL_S else []
    return []


def _shown(reading: Observation, conditions: dict[str, object]) -> str:
    return f"last reading at {reading.time_s:.3f} s: {reading}"


def timeline(played: Played) -> list[str]:
    """What a failure's message needs to tell its story: every event, every change of what the
    robot reported or its outputs did, and every stall of the player itself, in time order."""
    lines = [f"{at_s:8.3f} s  event {label!r}" for label, at_s in played.labels.items()]
    last: tuple[object, ...] | None = None
    previous_s: float | None = None
    for reading in played.readings:
        if previous_s is not None and reading.time_s - previous_s > STALL_S:
            lines.append(
                f"{reading.time_s:8.3f} s  no reading for {reading.time_s - previous_s:.3f} s"
            )
        previous_s = reading.time_s
        state = (
            reading.mode.name, reading.latched, reading.gear.name, reading.motors_enabled,
            reading.ebrake_engaged, reading.throttle_volts > 0.0, reading.regen_volts > 0.0,
            reading.lights.error_led, reading.error_flags,
        )  # fmt: skip
        if state != last:
            lines.append(
                f"{reading.time_s:8.3f} s  mode {state[0]} latched {state[1]} gear {state[2]}"
                f" enable {state[3]} e-brake {state[4]} throttle {reading.throttle_volts:.2f} V"
                f" regen {reading.regen_volts:.2f} V error LED {state[7]} flags {state[8]:#x}"
            )
            last = state
    return sorted(lines, key=lambda line: float(line.split()[0]))
