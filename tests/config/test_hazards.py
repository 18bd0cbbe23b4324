"""Unsafe combinations: numbers each within range that together break a promise of SAFETY.md."""

from __future__ import annotations

import pytest

from bywire.config import default_sim_config, parse_config
from bywire.config.hazards import unsafe_combinations

# (TOML, the keys the report must name)
UNSAFE = [
    (
        "[timeouts]\ncan_command_timeout_s = 0.5\nwatchdog_s = 0.2",
        ("timeouts.can_command_timeout_s", "timeouts.watchdog_s"),
    ),
    (
        "[timeouts.can_message_timeout_s]\nMovementCommand = 0.5",
        ("timeouts.can_message_timeout_s.MovementCommand", "timeouts.watchdog_s"),
    ),
    (
        "[timeouts]\nrc_timeout_s = 0.3\nwatchdog_s = 0.2",
        ("timeouts.rc_timeout_s", "timeouts.watchdog_s"),
    ),
    (
        "[supervisor]\ndebounce_frames = 14",
        ("supervisor.debounce_frames", "sim.rc_frame_period_s", "timeouts.rc_timeout_s"),
    ),
    (
        "[interlocks]\nunknown_speed_dwell_s = 0.2\ndirection_dwell_s = 0.5",
        ("interlocks.unknown_speed_dwell_s", "interlocks.direction_dwell_s"),
    ),
    (
        "[interlocks]\nunknown_speed_brake_norm = 0.3\n[hydrobrake]\nthreshold_norm = 0.5",
        ("interlocks.unknown_speed_brake_norm", "hydrobrake.threshold_norm"),
    ),
]


def test_the_simulators_defaults_are_safe_by_construction() -> None:
    assert unsafe_combinations(default_sim_config()) == []


@pytest.mark.parametrize(("text", "keys"), UNSAFE)
def test_each_unsafe_combination_is_reported_with_its_keys(
    text: str, keys: tuple[str, ...]
) -> None:
    found = unsafe_combinations(parse_config(text, "robot.toml"))
    assert [combination.keys for combination in found] == [keys]
    message = str(found[0])
    assert all(key in message for key in keys)
    assert "allowed" in message


def test_a_slow_lights_command_is_no_hazard_it_moves_nothing() -> None:
    text = "[timeouts.can_message_timeout_s]\nLightsCommand = 0.5\nControlCommand = 0.5"
    assert unsafe_combinations(parse_config(text, "robot.toml")) == []


def test_the_limit_itself_is_safe() -> None:
    at_the_limit = "[timeouts]\ncan_command_timeout_s = 0.2\nrc_timeout_s = 0.2\nwatchdog_s = 0.2"
    assert unsafe_combinations(parse_config(at_the_limit, "robot.toml")) == []
