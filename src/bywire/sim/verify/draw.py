"""Drawing `bywire verify`'s campaigns: random steps, and the episodes an operator makes of them.

Campaign `index` of seed `seed` is drawn from its own random source, so a run is the same for a
given seed and budget however many processes share it, and any one campaign can be drawn again
alone. A campaign starts armed and driving (by RC or by CAN), then goes on at random over every
action of `campaign.VOCABULARY` until `campaign_s` of simulated time.

Pure chance rarely strings together what happens on purpose, and the rules that are easiest to
get wrong sit exactly there: clearing a latched cause. So some steps bring a follow-up, each
with `FOLLOW_UP_CHANCE`, after a wait of `FOLLOW_UP_DELAY_S`:

- a fault that begins (`ENDINGS`) may end a while later, as a cable is plugged back in;
- a fault that ends may be followed by a re-arming: at CAN by the computer's re-enable (its
  throttle at zero first) or by the switch through STOP, at RC by the switch (`RE_ARM`);
- a brake or servo that breaks may meet a request that needs it (`DEMANDS`);
- a throttle or a turn may be met by a brake, a reversal or a stop while the robot moves
  (`IN_MOTION`).

A follow-up is a step like any other: it may bring its own, and the shrinker drops it alone.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import cast

from bywire.model import ControlMode, Gear
from bywire.sim.verify.actions import BRIDGE_ACTIONS
from bywire.sim.verify.campaign import OPERATOR, TAIL_S, VOCABULARY, Step
from bywire.sim.verify.fault_rules import IMPOSTOR_PERIOD_S

RC, CAN, STOP = ControlMode.RC, ControlMode.CAN, ControlMode.STOP
CAMPAIGN_S = 10.0
DELAY_S = (0.005, 0.6)  # the wait before each step, drawn uniformly, to the millisecond
WEIGHTS = {action: 4.0 if action in OPERATOR else 1.0 for action in VOCABULARY}
WEIGHTS.update(ebrake=0.25, encoder=0.25)  # lasting faults: rarer, or the robot stays stopped
WEIGHTS.update(estop=0.5)  # the E-stop: a stop every time, rarer than the operator
WEIGHTS.update(line=0.1, secoc=0.0)  # a dead line ends the campaign; authentication opens one
WEIGHTS.update(dict.fromkeys(BRIDGE_ACTIONS, 0.0))  # bridge campaigns' own (`draw_bridge.py`)
WEIGHTS.update(grade=0.0)  # drawn at the start, apart (`draw_bridge.draw_any`)
SECOC_CHANCE = 0.25
"""A campaign runs with authenticated commands (a second sender without the key is harmless
then, one with it is an impostor like any other)."""
FOLLOW_UP_CHANCE = 0.5
FOLLOW_UP_DELAY_S = (0.05, 1.2)

Episode = tuple[Step, ...]
"""Steps in order, each `delay_s` after the one before (the first's wait is drawn and added to
its `delay_s`, which is then the least wait)."""

ENDINGS: dict[tuple[str, object], Step] = {
    ("rc_link", False): Step(0.0, "rc_link", True),
    ("rc_failsafe", True): Step(0.0, "rc_failsafe", False),
    ("can_link", False): Step(0.0, "can_link", True),
    ("can_cable", False): Step(0.0, "can_cable", True),
    ("remote_stop", True): Step(0.0, "remote_stop", False),
    ("dac", "fail"): Step(0.0, "dac", "restore"),
    ("dac", "alternate"): Step(0.0, "dac", "restore"),
    **{("dac_slow", t): Step(0.0, "dac", "restore") for t in VOCABULARY["dac_slow"]},
    ("wheel_sensor", False): Step(0.0, "wheel_sensor", True),
    ("hydrobrake", False): Step(0.0, "hydrobrake", True),
    ("servo", False): Step(0.0, "servo", True),
    ("estop", "press"): Step(0.0, "estop", "release"),
    ("estop", "chatter"): Step(0.0, "estop", "release"),
    ("estop", "wire"): Step(0.0, "estop", "mend"),
}
"""A fault's beginning, and the step that ends it."""
RE_ENABLE: Episode = (Step(0.0, "can_throttle", 0.0), Step(0.05, "re_enable"))
RE_ARM: dict[ControlMode, tuple[Episode, ...]] = {
    CAN: (RE_ENABLE, RE_ENABLE, (Step(0.0, "arm", CAN),)),
    RC: ((Step(0.0, "arm", RC),),),
}
"""How the source the switch is at may be armed again once a fault is over."""
DEMANDS: dict[tuple[str, object], dict[ControlMode, Episode]] = {
    ("hydrobrake", False): {
        CAN: (Step(0.0, "can_brake", 1.0),),
        RC: (Step(0.0, "rc_throttle", -1.0),),
    },
    ("ebrake", False): {  # latent; the hydraulic brake fails as the source brakes at speed
        CAN: (Step(0.3, "hydrobrake", False), Step(0.0, "can_brake", 1.0)),
        RC: (Step(0.3, "hydrobrake", False), Step(0.0, "rc_throttle", -1.0)),
    },
    ("servo", False): {  # the monitor latches; the servo is freed, and the operator re-arms
        CAN: (Step(0.0, "can_steer", 0.5), Step(0.4, "servo", True), Step(0.1, "arm", CAN)),
        RC: (Step(0.0, "rc_steer", 0.5), Step(0.4, "servo", True), Step(0.1, "arm", RC)),
    },
}
"""What the source the switch is at asks of an actuator that just broke (and, for the servo,
whether the latch it caused clears once it is mended)."""
BRAKE_ON_THROTTLE: Episode = (Step(0.0, "can_brake", 1.0), Step(0.4, "can_brake", 0.0))
REVERSE_ROLLING: dict[ControlMode, Episode] = {  # up to speed, let go; reverse past the dwell
    RC: (
        Step(1.0, "rc_throttle", 0.0),
        Step(0.6, "rc_gear", Gear.REVERSE),
        Step(0.05, "rc_throttle", 0.8),
    ),
    CAN: (
        Step(1.0, "can_throttle", 0.0),
        Step(0.6, "can_gear", Gear.REVERSE),
        Step(0.05, "can_throttle", 0.6),
    ),
}
SENSOR_DIES_ROLLING: dict[ControlMode, tuple[Episode, ...]] = {  # then reverse, or re-arm first
    mode: (
        (
            Step(1.0, "wheel_sensor", False),
            replace(REVERSE_ROLLING[mode][0], delay_s=0.1),
            *REVERSE_ROLLING[mode][1:],
        ),
        (Step(1.0, "wheel_sensor", False), Step(0.05, "arm", mode), *REVERSE_ROLLING[mode][1:]),
    )
    for mode in (RC, CAN)
}


def _re_enable_after(least_s: float) -> Episode:
    """`RE_ENABLE`, its first step at least `least_s` after the step before."""
    return (replace(RE_ENABLE[0], delay_s=round(least_s, 3)), *RE_ENABLE[1:])


SECOND_SENDER_ROLLING: Episode = (  # then a re-enable once the id is trusted again
    Step(0.3, "impostor", 20),
    *_re_enable_after(20 * IMPOSTOR_PERIOD_S + 0.5),
)
BRAKES_FAIL_ROLLING: dict[ControlMode, Episode] = {  # the spring brake broken unnoticed
    mode: (Step(0.5, "ebrake", False), *DEMANDS[("ebrake", False)][mode]) for mode in (RC, CAN)
}
IN_MOTION: dict[tuple[str, object], dict[ControlMode, tuple[Episode, ...]]] = {
    **{
        ("can_throttle", t): {
            CAN: (
                BRAKE_ON_THROTTLE,
                REVERSE_ROLLING[CAN],
                *SENSOR_DIES_ROLLING[CAN],
                SECOND_SENDER_ROLLING,
                BRAKES_FAIL_ROLLING[CAN],
            )
        }
        for t in (0.2, 0.6)
    },
    ("rc_throttle", 0.8): {
        RC: (REVERSE_ROLLING[RC], *SENSOR_DIES_ROLLING[RC], BRAKES_FAIL_ROLLING[RC])
    },
    **{("rc_steer", s): {RC: ((Step(0.0, "switch", STOP),),)} for s in (-0.6, 0.5)},
    **{("can_steer", s): {CAN: ((Step(0.0, "remote_stop", True),),)} for s in (-0.5, 0.5)},
}
"""What may happen while the robot moves: the computer brakes without taking its throttle back
(the brake must win); the source in command lets go and reverses while the robot still rolls
(the interlock holds the gear until standstill), also after the wheel sensor died at speed, and
after a quick re-arming that acknowledged its fault (a dead sensor's standstill must not count);
a second sender takes the computer's id, and the computer asks to re-enable once it is trusted
again (only the switch may clear CAN_UNTRUSTED);
the operator or the computer stops it with the steering turned (STOP holds the steering where
it is)."""
ROLLING_THROTTLE = {RC: 0.8, CAN: 0.6}
ROLLING_OPENING_CHANCE = 0.25
"""A campaign may open with an episode of `IN_MOTION` at once: later, earlier faults have often
left the robot standing in STOP, where the episode tests nothing."""
ENDED = frozenset((step.action, step.value) for step in ENDINGS.values())


def switch_after(switch: ControlMode, step: Step) -> ControlMode:
    """Where the mode switch is after `step`, as the campaign compiler moves it."""
    if step.action in {"arm", "switch"}:
        return cast(ControlMode, step.value)
    if step.action in {"handover", "handover_steer"}:
        return CAN if switch is RC else RC
    if step.action == "switch_between":
        return STOP
    return switch


def follow_ups(switch: ControlMode, step: Step) -> list[Episode]:
    """The episodes that may follow `step` on purpose, the switch at `switch` after it."""
    key = (step.action, step.value)
    episodes: list[Episode] = []
    if switch in DEMANDS.get(key, {}):
        episodes.append(DEMANDS[key][switch])
    episodes.extend(IN_MOTION.get(key, {}).get(switch, ()))
    if step.action == "impostor" and switch is CAN:
        episodes.append(after_impostor(cast(int, step.value)))
    if key in ENDINGS:
        episodes.append((ENDINGS[key],))
    if key in ENDED:
        episodes.extend(RE_ARM.get(switch, ()))
    return episodes


def after_impostor(frames: int) -> Episode:
    """The computer asks to re-enable once a second sender's `frames` are over: CAN_UNTRUSTED
    is the switch's to clear (S8), whether the id is trusted again by then or not."""
    return _re_enable_after(frames * IMPOSTOR_PERIOD_S + 0.05)


def _drawn(episodes: Sequence[Episode], rng: random.Random) -> list[Step]:
    """One of `episodes`, its first step's wait drawn (its own `delay_s` the least)."""
    first, *rest = rng.choice(episodes)
    wait_s = round(first.delay_s + rng.uniform(*FOLLOW_UP_DELAY_S), 3)
    return [Step(wait_s, first.action, first.value), *rest]


def draw_campaign(seed: int, index: int, campaign_s: float = CAMPAIGN_S) -> list[Step]:
    """Campaign `index` of `seed`: armed and driving first, then random steps to `campaign_s`."""
    rng = random.Random(f"bywire-verify:{seed}:{index}")
    mode = rng.choice([RC, CAN])
    throttle = rng.choice([0.0, 0.3, 0.6, 0.6])
    source = "rc_throttle" if mode is RC else "can_throttle"
    steps = [Step(0.2, "arm", mode), Step(0.15, source, throttle)]
    upcoming: list[Step] = []
    # Drawn apart, so that the campaigns that open otherwise stay what they were.
    opening = random.Random(f"bywire-verify-opening:{seed}:{index}")
    if opening.random() < ROLLING_OPENING_CHANCE:
        steps[-1] = Step(0.15, source, ROLLING_THROTTLE[mode])
        upcoming = _drawn(IN_MOTION[(source, ROLLING_THROTTLE[mode])][mode], opening)
    if random.Random(f"bywire-verify-secoc:{seed}:{index}").random() < SECOC_CHANCE:
        steps.insert(0, Step(0.0, "secoc", True))
    return walked(steps, upcoming, rng, WEIGHTS, switch=mode, campaign_s=campaign_s)


def walked(
    steps: list[Step],
    upcoming: list[Step],
    rng: random.Random,
    weights: Mapping[str, float],
    *,
    switch: ControlMode,
    campaign_s: float,
    follow: Callable[[ControlMode, Step], list[Episode]] | None = None,
) -> list[Step]:
    """`steps` (the opening, `switch` where they leave the mode switch) walked on to
    `campaign_s`: `upcoming` first, then actions drawn by `weights`, each step maybe bringing its
    follow-ups (`follow`, else `follow_ups`)."""
    follow = follow_ups if follow is None else follow
    actions, chances = list(weights), list(weights.values())
    at_s = sum(step.delay_s for step in steps)
    while True:
        if upcoming:
            step = upcoming.pop(0)
        else:
            action = rng.choices(actions, chances)[0]
            step = Step(round(rng.uniform(*DELAY_S), 3), action, rng.choice(VOCABULARY[action]))
        if at_s + step.delay_s > campaign_s - TAIL_S:
            return steps
        at_s = round(at_s + step.delay_s, 3)
        steps.append(step)
        switch = switch_after(switch, step)
        episodes = follow(switch, step)
        if episodes and rng.random() < FOLLOW_UP_CHANCE:
            upcoming[:0] = _drawn(episodes, rng)
