"""Combinations of numbers that make a robot unsafe by construction, whatever happens to it.

Each key may be within its own range while two of them together break a promise of
`docs/SAFETY.md`. `bywire verify` reports these before it runs a single campaign (a random search
is the wrong tool for what arithmetic shows), and `bywire config` lists them as warnings.
"""

from __future__ import annotations

from dataclasses import dataclass

from bywire.config.model import RobotConfig
from bywire.config.reader import number_text
from bywire.model import MovementCommand


@dataclass(frozen=True, slots=True)
class UnsafeCombination:
    """Keys that together are unsafe, why, and what to change."""

    keys: tuple[str, ...]
    problem: str
    fix: str

    def __str__(self) -> str:
        return f"{' + '.join(self.keys)}: {self.problem}; {self.fix}"


def unsafe_combinations(robot: RobotConfig) -> list[UnsafeCombination]:
    """Every unsafe combination in `robot`, in the order of `docs/SAFETY.md`'s hazard table."""
    found: list[UnsafeCombination] = []
    timeouts, interlocks = robot.timeouts, robot.interlocks
    watchdog_s = timeouts.watchdog_s
    # The movement command is the one that drives: its age limit is the one that matters here
    # (a stale LightsCommand or ControlCommand moves nothing).
    movement_s = timeouts.can_timeout_s(MovementCommand.__name__)
    movement_key = (
        "timeouts.can_command_timeout_s"
        if movement_s == timeouts.can_command_timeout_s
        else f"timeouts.can_message_timeout_s.{MovementCommand.__name__}"
    )
    for key, timeout_s, what in (
        ("timeouts.rc_timeout_s", timeouts.rc_timeout_s, "a lost RC link"),
        (movement_key, movement_s, "a silent computer"),
    ):
        if timeout_s > watchdog_s:
            found.append(
                UnsafeCombination(
                    (key, "timeouts.watchdog_s"),
                    f"{key} = {number_text(timeout_s)} s is longer than the watchdog's"
                    f" {number_text(watchdog_s)} s: {what} drives on longer than a stalled loop"
                    " would",
                    f"allowed {key} <= timeouts.watchdog_s",
                )
            )
    frames = robot.supervisor.debounce_frames
    frame_s = robot.sim.rc_frame_period_s
    debounce_s = frames * frame_s
    if debounce_s >= timeouts.rc_timeout_s:
        found.append(
            UnsafeCombination(
                ("supervisor.debounce_frames", "sim.rc_frame_period_s", "timeouts.rc_timeout_s"),
                f"{frames} frames of {number_text(frame_s)} s = {number_text(debounce_s)} s of"
                f" debounce is not shorter than timeouts.rc_timeout_s ="
                f" {number_text(timeouts.rc_timeout_s)} s: a switch position would be judged on"
                " frames older than the link is trusted",
                "allowed supervisor.debounce_frames * sim.rc_frame_period_s <"
                " timeouts.rc_timeout_s",
            )
        )
    if interlocks.unknown_speed_dwell_s < interlocks.direction_dwell_s:
        found.append(
            UnsafeCombination(
                ("interlocks.unknown_speed_dwell_s", "interlocks.direction_dwell_s"),
                f"without a trusted speed the robot would wait"
                f" {number_text(interlocks.unknown_speed_dwell_s)} s before a direction change,"
                f" less than the {number_text(interlocks.direction_dwell_s)} s it waits with one",
                "allowed interlocks.unknown_speed_dwell_s >= interlocks.direction_dwell_s",
            )
        )
    threshold = robot.hydrobrake.threshold_norm
    if interlocks.unknown_speed_brake_norm < threshold:
        found.append(
            UnsafeCombination(
                ("interlocks.unknown_speed_brake_norm", "hydrobrake.threshold_norm"),
                f"the brake the no-sensor rule demands"
                f" ({number_text(interlocks.unknown_speed_brake_norm)}) is below the hydraulic"
                f" brake's threshold ({number_text(threshold)}): the robot would change"
                " direction without the brake ever applied",
                "allowed interlocks.unknown_speed_brake_norm >= hydrobrake.threshold_norm",
            )
        )
    return found
