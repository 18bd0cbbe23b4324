"""Every condition an expectation of a scenario may state, in one table: its key, what it means,
what its value may be (checked when the scenario loads) and when it holds in an observation.

A new condition is a row here (and, if the robot shows something new, a field of
`Observation`); a new light output is a condition by itself (`LAMPS`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from bywire.control.lights import LIGHT_LINES, LightLine
from bywire.sim.observe import Observation
from bywire.sim.scenario_values import MODES, UNIT, Check, flag, number, one_of

Holds = Callable[[Observation, Any], bool]


@dataclass(frozen=True, slots=True)
class Condition:
    """One expectation condition: `key = value` in a scenario's `[[expect]]`."""

    key: str
    description: str
    check: Check
    holds: Holds


def _lamp(name: str, light: LightLine) -> Condition:
    """`<line> = true/false`: the light output `name` (a field of `LightOutputs`) on its line."""
    return Condition(
        light.line,
        f"{light.description} on",
        flag,
        lambda o, wanted: getattr(o.lights, name) is bool(wanted),
    )


LAMPS = tuple(_lamp(name, light) for name, light in LIGHT_LINES if not light.blinks)
"""One condition per steady light output (a blinking one has no level to expect)."""

VOLTS = number(0.0, 5.5, "V")
SPEED = number(-30.0, 30.0, "m/s")
TIME = number(0.0, 1e6, "s")

# fmt: off
CONDITIONS: tuple[Condition, ...] = (
    Condition("mode", "control mode: stop, rc or can", one_of(MODES),
              lambda o, wanted: o.mode.name.lower() == str(wanted).lower()),
    Condition("latched", "STOP is latched (true/false)", flag,
              lambda o, wanted: o.latched is bool(wanted)),
    Condition("throttle_volts_max", "throttle DAC output at most this (V)", VOLTS,
              lambda o, wanted: o.throttle_volts <= float(wanted)),
    Condition("throttle_volts_min", "throttle DAC output at least this (V)", VOLTS,
              lambda o, wanted: o.throttle_volts >= float(wanted)),
    Condition("motors_enabled", "the motors' enable line", flag,
              lambda o, wanted: o.motors_enabled is bool(wanted)),
    Condition("drive_safe", "throttle at 0 V and the motors disabled or braking by "
              "regeneration (a controlled stop)", flag,
              lambda o, wanted: o.drive_safe is bool(wanted)),
    Condition("regen_volts_min", "regenerative brake DAC output at least this (V)", VOLTS,
              lambda o, wanted: o.regen_volts >= float(wanted)),
    Condition("ebrake_engaged", "the emergency brake is engaged", flag,
              lambda o, wanted: o.ebrake_engaged is bool(wanted)),
    Condition("speed_min_mps", "vehicle speed at least this (m/s, signed)", SPEED,
              lambda o, wanted: o.speed_mps >= float(wanted)),
    Condition("speed_max_mps", "vehicle speed at most this (m/s, signed)", SPEED,
              lambda o, wanted: o.speed_mps <= float(wanted)),
    *LAMPS,
    Condition("hydrobrake_duty_min", "hydraulic brake PWM duty at least this", UNIT,
              lambda o, wanted: o.hydrobrake_duty >= float(wanted)),
    Condition("steering_pulse_min_s", "the steering pulse at least this (s)", TIME,
              lambda o, wanted: o.steering_pulse_s >= float(wanted)),
    Condition("steering_pulse_max_s", "the steering pulse at most this (s)", TIME,
              lambda o, wanted: o.steering_pulse_s <= float(wanted)),
    Condition("bridge_unshown_drop", "the ROS 2 bridge refused a set-point or stopped although"
              " its planner publishes, and /diagnostics has not shown it (counted, inputs WARN or"
              " ERROR) within two periods (B3; a computer = \"bridge\" scenario)", flag,
              lambda o, wanted: o.bridge_unshown_drop is bool(wanted)),
    Condition("bridge_throttle_max_norm", "the throttle the ROS 2 bridge asked for in its latest"
              " period at most this (a computer = \"bridge\" scenario)", UNIT,
              lambda o, wanted: o.bridge_throttle_norm is not None
              and o.bridge_throttle_norm <= float(wanted)),
    Condition("steering_held_since_s", "the steering pulse has not changed since this time (s)",
              TIME, lambda o, wanted: o.steering_changed_at_s <= float(wanted)),
)
# fmt: on
BY_KEY: dict[str, Condition] = {condition.key: condition for condition in CONDITIONS}


def conditions_hold(observation: Observation, conditions: Mapping[str, Any]) -> bool:
    """True when every condition of an expectation holds in this observation."""
    return all(BY_KEY[key].holds(observation, wanted) for key, wanted in conditions.items())
