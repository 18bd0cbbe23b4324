"""`[limits] max_speed_mps` and `[vehicle]`'s flat-ground calibration: read, refused when out of
range (naming the key and the range), and the governor's configuration derived from them."""

from __future__ import annotations

import pytest

from bywire.config import parse_config
from bywire.config.render import describe
from bywire.config.speed_limit import (
    DEFAULT_MAX_SPEED_MPS,
    LimitsSection,
    enforcement,
    governor_config,
)
from bywire.config.vehicle import SIM_FLAT_SPEEDS_MPS, SIM_FLAT_THROTTLES, VehicleSection
from bywire.errors import ConfigError
from bywire.hal.simulated.vehicle_model import (
    ActuatorInputs,
    VehicleConfig,
    drive_accel_mps2,
    resistance_mps2,
)


def test_no_limit_is_a_deliberate_none_that_writes_and_reads_back() -> None:
    robot = parse_config('[limits]\nmax_speed_mps = "none"')
    assert robot.limits.max_speed_mps is None
    assert 'max_speed_mps = "none"' in describe(robot)
    assert parse_config(describe(robot)) == robot
    with pytest.raises(ConfigError, match=r'expected a number in 0\.1\.\.30 m/s or "none"'):
        parse_config('[limits]\nmax_speed_mps = "off"')


def test_a_file_without_the_key_gets_the_default_limit_not_none() -> None:
    assert parse_config("").limits.max_speed_mps == DEFAULT_MAX_SPEED_MPS
    assert parse_config("[limits]\nmax_speed_mps = 4.2").limits.max_speed_mps == 4.2


@pytest.mark.parametrize("value", ["0.05", "30.5", "-1", '"fast"', "nan", "inf"])
def test_an_out_of_range_limit_is_refused_naming_key_and_range(value: str) -> None:
    with pytest.raises(ConfigError, match=r"limits\.max_speed_mps = .*0\.1\.\.30 m/s"):
        parse_config(f"[limits]\nmax_speed_mps = {value}")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("flat_speeds_mps = [0.0, 2.0, 1.0]", r"vehicle\.flat_speeds_mps .*not strictly rising"),
        ("flat_speeds_mps = [0.0]", r"vehicle\.flat_speeds_mps .*expected an array of 2\.\.32"),
        ("flat_speeds_mps = [0.0, 31.0]", r"vehicle\.flat_speeds_mps .*out of range"),
        ("flat_throttles = [0.1, 0.9, 0.5, 0.6, 0.7, 0.8, 0.9]", r"flat_throttles .*not rising"),
        ("flat_throttles = [0.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7]", r"flat_throttles .*0\.\.1"),
        ("flat_throttles = [0.1, true, 0.2, 0.3, 0.4, 0.5, 0.6]", r"flat_throttles .*out of range"),
        ("flat_throttles = [0.1, 0.2]", r"flat_throttles .*one throttle for each of the 7"),
    ],
)
def test_a_bad_calibration_is_refused_naming_the_key(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_config(f"[vehicle]\n{text}")


def test_the_ceiling_is_derived_from_the_limit_and_the_calibration() -> None:
    robot = parse_config(
        "[limits]\nmax_speed_mps = 1.5\n[vehicle]\n"
        "flat_speeds_mps = [0.0, 1.0, 2.0]\nflat_throttles = [0.1, 0.3, 0.7]"
    )
    governor = governor_config(robot.limits, robot.vehicle)
    assert governor.max_speed_mps == 1.5
    assert governor.ceiling_throttle_norm == pytest.approx(0.5)
    assert governor_config(LimitsSection(None), robot.vehicle).max_speed_mps is None


def test_enforcement_states_the_governor_and_the_ceiling_with_its_numbers() -> None:
    text = "\n".join(enforcement(LimitsSection(2.5), VehicleSection()))
    assert "speed limit 2.5 m/s (9.0 km/h)" in text
    assert "brake begins above 2.75 m/s and is full at 3.00 m/s" in text
    assert "throttle ceiling of 0.462, derived from the limit and the vehicle's calibration" in text
    assert enforcement(LimitsSection(None), VehicleSection()) == [
        'no speed limit: the file says max_speed_mps = "none"; the controller limits nothing'
    ]


def test_the_default_calibration_holds_each_speed_on_the_simulated_robot() -> None:
    config = VehicleConfig()
    for speed, throttle in zip(SIM_FLAT_SPEEDS_MPS, SIM_FLAT_THROTTLES, strict=True):
        inputs = ActuatorInputs(
            throttle_volts=throttle * config.full_scale_volts,
            motors_enable=True,
            motors_forward=True,
            ebrake_release=True,
        )
        accel = drive_accel_mps2(speed, inputs, config) - resistance_mps2(inputs, config)
        assert accel == pytest.approx(0.0, abs=0.002)
