"""Drawing `bywire verify`'s bridge campaigns: the ROS 2 bridge's CAN side is the computer, fed by
a simulated planner, among the robot faults that matter to it.

A share (`BRIDGE_SHARE`) of a run's campaigns are bridge campaigns, which of them decided by a
random source of their own (`is_bridge_campaign`), so every other campaign is drawn exactly as
`draw.draw_campaign` draws it. A bridge campaign opens with the bridge's parameters (its defaults
or legal edges, `actions.BRIDGE_PRESETS`), the robot armed into CAN, `~/enable` called and the
planner publishing a speed; then random steps of `BRIDGE_WEIGHTS`: the planner's speed, curvature,
silence, stamp lag and rate, the services, and the robot's faults (the wheel sensor's death, the
brakes, the bridge's own silence, the CAN cable, RC takeover). As in `draw.py`, some steps bring
a follow-up: a fault that ends, `~/enable` after it, a planner that publishes again; and a
campaign may open in motion with an episode the bridge must survive (`ROLLING`).
"""

from __future__ import annotations

import random

from bywire.model import ControlMode, Gear
from bywire.sim.verify.actions import BRIDGE_PRESETS
from bywire.sim.verify.campaign import Step
from bywire.sim.verify.draw import (
    CAMPAIGN_S,
    ENDED,
    ENDINGS,
    Episode,
    draw_campaign,
    walked,
)

RC, CAN = ControlMode.RC, ControlMode.CAN
BRIDGE_SHARE = 0.2
SLOPE_SHARE = 0.25
"""The share of the other campaigns driven downhill from their start."""
SLOPE_GRADES = (-0.05, -0.1)
"""Their grades: 5 % and 10 % downhill (the simulated robot's brakes hold 25 % and more)."""
"""The share of a run's campaigns that are bridge campaigns."""
BRIDGE_WEIGHTS: dict[str, float] = {
    "planner_speed": 4.0,
    "planner_turn": 1.0,
    "planner_link": 1.5,
    "planner_lag": 1.5,
    "planner_rate": 1.0,
    "bridge_enable": 2.0,
    "bridge_remote_stop": 0.5,
    "arm": 0.5,
    "switch": 0.3,
    "flick": 0.5,
    "rc_throttle": 0.5,
    "rc_steer": 0.3,
    "wheel_sensor": 0.5,
    "hydrobrake": 0.5,
    "ebrake": 0.1,
    "can_link": 0.5,  # the bridge's link stops (its process died), or runs again
    "can_cable": 0.2,
    "rc_link": 0.3,
    "can_flood": 0.2,
    "servo": 0.2,
}
"""What a bridge campaign draws, and how often (the computer's own actions most)."""
ENABLE: Episode = (Step(0.0, "bridge_enable"),)
PLANNER_BACK: Episode = (Step(0.0, "planner_link", True),)
BRIDGE_ENDINGS: dict[tuple[str, object], Step] = {
    **{key: step for key, step in ENDINGS.items() if key[0] in BRIDGE_WEIGHTS},
    ("planner_link", False): Step(0.0, "planner_link", True),
    ("bridge_remote_stop", True): Step(0.0, "bridge_remote_stop", False),
}
"""A fault's (or the planner's silence's) beginning, and the step that ends it."""
RE_ARM: dict[ControlMode, tuple[Episode, ...]] = {
    CAN: (ENABLE, ENABLE, (Step(0.0, "arm", CAN), Step(0.2, "bridge_enable"))),
    RC: ((Step(0.0, "arm", RC),),),
}
"""How the source the switch is at is armed again once a fault is over: at CAN, `~/enable`."""
ROLLING: tuple[Episode, ...] = (
    (Step(2.5, "wheel_sensor", False),),  # the speed loop must not run away (B1)
    (Step(4.0, "planner_link", False), Step(2.0, "planner_link", True)),  # the ramp (B2)
    (Step(0.5, "planner_lag", 0.17),),  # stamps that age out between messages (B3)
    (Step(2.5, "planner_speed", -0.5),),  # a reversal while rolling
    (Step(2.5, "switch", RC), Step(0.3, "rc_throttle", 0.3)),  # RC takes over at speed
    (Step(2.5, "hydrobrake", False), Step(0.3, "planner_link", False)),  # a stop without it
)
"""What may happen once the bridge drives at speed: a campaign may open with one."""
ROLLING_CHANCE = 0.5
OPENING_SPEEDS = (0.5, 1.0, 2.0, 2.0)


def is_bridge_campaign(seed: int, index: int) -> bool:
    """Whether campaign `index` of `seed` is a bridge campaign (a random source of its own)."""
    return random.Random(f"bywire-verify-bridge:{seed}:{index}").random() < BRIDGE_SHARE


def draw_any(seed: int, index: int, campaign_s: float = CAMPAIGN_S) -> list[Step]:
    """Campaign `index` of `seed`, a bridge campaign or `draw_campaign`'s."""
    if is_bridge_campaign(seed, index):
        return draw_bridge_campaign(seed, index, campaign_s)
    return on_a_slope(draw_campaign(seed, index, campaign_s), seed, index)


def _both_brakes_fail(steps: list[Step]) -> bool:
    """The spring brake and the hydraulic brake both fail in the campaign: downhill nothing then
    holds a robot in STOP (a double fault no controller can act on, beyond H7's and H11's
    assumption of a brake), so such a campaign stays on the flat."""
    actions = {(step.action, step.value) for step in steps}
    return ("ebrake", False) in actions and ("hydrobrake", False) in actions


def _reverses(steps: list[Step]) -> bool:
    """The campaign selects reverse: downhill, a reverse throttle weaker than gravity rolls the
    robot forward against its drive (H4), which no rule of the controller prevents yet
    (docs/SAFETY.md, "What is not covered"), so such a campaign stays on the flat."""
    return any(
        step.action in ("rc_gear", "can_gear") and step.value is Gear.REVERSE for step in steps
    )


def on_a_slope(steps: list[Step], seed: int, index: int) -> list[Step]:
    """Some campaigns are driven downhill from the start (a random source of its own, so the
    others are drawn as before): gravity carries the robot towards and past its speed limit
    unless the governor holds it (H11, docs/SAFETY.md row 67)."""
    rng = random.Random(f"bywire-verify-grade:{seed}:{index}")
    if rng.random() >= SLOPE_SHARE or _both_brakes_fail(steps) or _reverses(steps):
        return steps
    return [Step(0.0, "grade", rng.choice(SLOPE_GRADES)), *steps]


def follow_ups(switch: ControlMode, step: Step) -> list[Episode]:
    """The episodes that may follow `step` on purpose in a bridge campaign."""
    key = (step.action, step.value)
    episodes: list[Episode] = []
    if key in BRIDGE_ENDINGS:
        episodes.append((BRIDGE_ENDINGS[key],))
    if key in ENDED or key == ("bridge_remote_stop", False):
        episodes.extend(RE_ARM.get(switch, ()))
    return episodes


def draw_bridge_campaign(seed: int, index: int, campaign_s: float = CAMPAIGN_S) -> list[Step]:
    """Bridge campaign `index` of `seed`: enabled and driving first, then random steps."""
    rng = random.Random(f"bywire-verify-bridge-steps:{seed}:{index}")
    preset = rng.choice(tuple(BRIDGE_PRESETS))
    steps = [
        Step(0.0, "bridge", preset),
        Step(0.2, "arm", CAN),
        Step(0.15, "bridge_enable"),
        Step(0.1, "planner_speed", rng.choice(OPENING_SPEEDS)),
        Step(0.0, "planner_link", True),
    ]
    upcoming: list[Step] = list(rng.choice(ROLLING)) if rng.random() < ROLLING_CHANCE else []
    return walked(
        steps, upcoming, rng, BRIDGE_WEIGHTS, switch=CAN, campaign_s=campaign_s, follow=follow_ups
    )
