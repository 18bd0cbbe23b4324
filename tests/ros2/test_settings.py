"""The bridge's parameters: defaults valid, each bad value refused by name and range, and the
default maps are the simulated robot's own (so the speed loop starts from the right throttle)."""

from __future__ import annotations

import dataclasses
from dataclasses import replace
from pathlib import Path

import pytest

from bywire.errors import ConfigError
from bywire.hal.simulated.vehicle_model import (
    ActuatorInputs,
    VehicleConfig,
    drive_accel_mps2,
    resistance_mps2,
)
from bywire.ros2.settings import (
    DEFAULTS,
    RANGES,
    SHELL_PARAMETERS,
    BridgeSettings,
    capped_by,
    interpolate,
    parameter_defaults,
    settings_from,
)


def test_the_defaults_pass_their_own_checks() -> None:
    assert settings_from({}) == BridgeSettings()
    assert settings_from(parameter_defaults()) == DEFAULTS


def test_every_number_has_a_range() -> None:
    numbers = {f.name for f in dataclasses.fields(BridgeSettings) if f.type == "float"}
    assert numbers == set(RANGES)


@pytest.mark.parametrize(
    ("name", "value", "quoted"),
    [
        ("stop_ramp_s", 0.6, "0.3..0.5 s"),
        ("stop_ramp_s", 0.2, "0.3..0.5 s"),
        ("cmd_timeout_s", 0.0, "0.02..2 s"),
        ("max_stamp_age_s", 5.0, "0.02..2 s"),
        ("kp", -1.0, "0..20"),
        ("max_speed_mps", 0.0, "> 0"),
        ("hold_brake", 0.0, "0.1..1"),
        ("stop_ramp_s", "fast", "expected a number"),
        ("stop_ramp_s", True, "expected a number"),
        ("feedforward_throttles", "0.1", "expected an array"),
    ],
)
def test_a_bad_parameter_is_refused_by_name_value_and_range(
    name: str, value: object, quoted: str
) -> None:
    with pytest.raises(ConfigError) as caught:
        settings_from({name: value})
    assert name in str(caught.value)
    assert quoted in str(caught.value)


@pytest.mark.parametrize(
    ("values", "quoted"),
    [
        ({"feedforward_speeds_mps": [0.0, 1.0]}, "same number of points"),
        ({"brake_decels_mps2": [0.1, 0.1, 5.0]}, "must rise strictly"),
        ({"brake_norms": [0.0, 0.6, 0.5]}, "must not fall"),
        ({"brake_norms": [0.0, 0.5, 1.5]}, "out of range"),
        ({"brake_decels_mps2": [1.0], "brake_norms": [1.0]}, "2..32"),
    ],
)
def test_a_bad_map_is_refused(values: dict[str, object], quoted: str) -> None:
    with pytest.raises(ConfigError, match=quoted):
        settings_from(values)


def test_an_unknown_parameter_is_refused() -> None:
    with pytest.raises(ConfigError, match="unknown parameter stop_ramp"):
        settings_from({"stop_ramp": 0.4})


def _accel_mps2(speed_mps: float, throttle_norm: float, config: VehicleConfig) -> float:
    drive = ActuatorInputs(
        throttle_volts=throttle_norm * config.full_scale_volts,
        motors_enable=True,
        motors_forward=True,
        ebrake_release=True,
    )
    return drive_accel_mps2(speed_mps, drive, config) - resistance_mps2(drive, config)


def test_the_feedforward_map_holds_each_speed_on_the_simulated_robot() -> None:
    config = VehicleConfig()
    for speed, throttle in zip(
        DEFAULTS.feedforward_speeds_mps, DEFAULTS.feedforward_throttles, strict=True
    ):
        assert _accel_mps2(speed, throttle, config) == pytest.approx(0.0, abs=0.002)


def test_the_brake_map_gives_each_deceleration_on_the_simulated_robot() -> None:
    config = VehicleConfig()
    for decel, brake in zip(DEFAULTS.brake_decels_mps2, DEFAULTS.brake_norms, strict=True):
        inputs = ActuatorInputs(
            regen_volts=brake * config.full_scale_volts,
            motors_enable=True,
            ebrake_release=True,
            hydraulic_duty=max(0.0, (brake - 0.5) / 0.5),  # the default threshold, Figure 13
        )
        assert resistance_mps2(inputs, config) == pytest.approx(decel)


def test_interpolation_holds_at_the_ends_and_is_linear_between() -> None:
    xs, ys = (0.0, 1.0, 3.0), (0.0, 0.5, 0.5)
    assert interpolate(xs, ys, -1.0) == 0.0
    assert interpolate(xs, ys, 0.5) == 0.25
    assert interpolate(xs, ys, 2.0) == 0.5
    assert interpolate(xs, ys, 9.0) == 0.5


def test_docs_ros2_lists_every_parameter_with_its_default_and_range() -> None:
    text = (Path(__file__).parents[2] / "docs" / "ROS2.md").read_text(encoding="utf-8")
    rows = {
        line.split("|")[1].strip(" `"): line for line in text.splitlines() if line.startswith("| `")
    }
    for name, default in parameter_defaults().items():
        values = default if isinstance(default, tuple) else (default,)
        assert f"| {', '.join(f'{value:g}' for value in values)} |" in rows[name], name
        if name in RANGES:
            assert f"| {RANGES[name]} |" in rows[name], name
    for name, value in SHELL_PARAMETERS.items():
        shown = str(value).lower() if isinstance(value, bool) else f"`{value}`"
        assert f"| {shown} |" in rows[name], name


def test_the_robots_speed_limit_caps_the_speed_gates_and_nothing_else() -> None:
    capped = capped_by(DEFAULTS, 1.5)
    assert (capped.max_speed_mps, capped.max_reverse_speed_mps) == (1.5, 0.8)
    assert capped_by(DEFAULTS, 0.5).max_reverse_speed_mps == 0.5
    assert capped_by(DEFAULTS, 9.0) == DEFAULTS  # a limit above the gates changes nothing
    assert capped_by(DEFAULTS, None) is DEFAULTS
    assert replace(capped, max_speed_mps=2.0, max_reverse_speed_mps=0.8) == DEFAULTS
