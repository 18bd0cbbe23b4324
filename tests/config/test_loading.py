"""Loading: shipped files validate, defaults match Table 1, I/O and TOML errors name the place."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from bywire.config import (
    GpioLine,
    RobotConfig,
    as_dict,
    default_sim_config,
    describe,
    load_config,
    output_lines,
    parse_config,
)
from bywire.errors import ConfigError
from bywire.hal.hardware import OUTPUT_NAMES
from tests.config.toml_keys import leaf_keys
from tests.runtime.test_schedule import TABLE_1

ROOT = Path(__file__).resolve().parents[2]
ALBERT = ROOT / "config" / "albert.toml"
SIM = ROOT / "src" / "bywire" / "defaults" / "sim.toml"


def test_packaged_sim_default_is_the_dataclass_default() -> None:
    config = default_sim_config()
    assert config.backend == "sim"
    assert config == RobotConfig()


def test_albert_loads_as_the_reference_robot_on_linux() -> None:
    config = load_config(ALBERT)
    assert (config.name, config.backend) == ("albert", "linux")
    assert (config.can.interface, config.can.channel) == ("socketcan", "can0")
    assert config.can.bitrate_bps == 500_000
    assert (config.rc.port, config.rc.baud) == ("/dev/ttyAMA0", 115_200)
    assert (config.drive.dac.i2c_bus, config.drive.dac.address) == (1, 0x4C)
    assert config.drive.motors_enable == GpioLine("pinctrl-bcm2711", "GPIO5")


@pytest.mark.parametrize("path", [SIM, ALBERT], ids=["sim", "albert"])
def test_defaults_are_table_1_rates_and_100_ms_timeouts(path: Path) -> None:
    config = load_config(path)
    tasks, timeouts = config.tasks, config.timeouts
    rates = dict(tasks.rates_hz)
    assert {name: rates.get(name) for name in TABLE_1} == TABLE_1
    assert (timeouts.rc_timeout_s, timeouts.can_command_timeout_s) == (0.100, 0.100)
    assert timeouts.watchdog_s == 0.200
    assert config.steering.pwm.frequency_hz == 50.0
    assert config.hydrobrake.threshold_norm == 0.5


def test_empty_file_takes_every_default() -> None:
    assert parse_config("") == RobotConfig()


@pytest.mark.parametrize("path", [SIM, ALBERT], ids=["sim", "albert"])
def test_shipped_files_spell_out_every_key(path: Path) -> None:
    written = set(leaf_keys(tomllib.loads(path.read_text(encoding="utf-8"))))
    resolved = set(leaf_keys(as_dict(load_config(path))))
    assert resolved - written == set()


def test_every_albert_key_has_a_comment() -> None:
    assignments = [
        line
        for line in ALBERT.read_text(encoding="utf-8").splitlines()
        if re.match(r"\s*[a-z_]+\s*=", line)
    ]
    assert len(assignments) > 60
    assert [line for line in assignments if "#" not in line] == []


def test_output_lines_name_every_hardware_output() -> None:
    lines = output_lines(load_config(ALBERT))
    assert list(lines) == list(OUTPUT_NAMES)
    assert lines["ebrake_release"] == GpioLine("pinctrl-bcm2711", "GPIO17")
    assert len(set(lines.values())) == len(lines)


@pytest.mark.parametrize("path", [SIM, ALBERT], ids=["sim", "albert"])
def test_describe_is_toml_that_loads_back_to_the_same_config(path: Path) -> None:
    config = load_config(path)
    assert parse_config(describe(config), "described") == config


def test_describe_mentions_resolved_values() -> None:
    text = describe(load_config(ALBERT))
    assert 'backend = "linux"' in text
    assert 'interface = "socketcan"' in text
    assert "address = 0x4C" in text
    assert "bitrate_bps = 500000" in text
    assert 'motors_enable = "GPIO5"' in text
    assert "[timeouts]\nrc_timeout_s = 0.1\n" in text


def test_as_dict_keeps_a_line_on_another_chip_explicit() -> None:
    config = parse_config('[lights]\nerror_led = { chip = "/dev/gpiochip4", line = 7 }')
    lights = as_dict(config)["lights"]
    assert isinstance(lights, dict)
    assert lights["error_led"] == {"chip": "/dev/gpiochip4", "line": 7}
    assert lights["low_beam"] == "LOW_BEAM"
    assert "clock_hz" not in str(as_dict(config)["can"])


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    path = tmp_path / "nowhere" / "robot.toml"
    with pytest.raises(ConfigError, match=re.escape(str(path))):
        load_config(path)


def test_unreadable_path_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(
        ConfigError, match=f"{re.escape(str(tmp_path))}: configuration file is a directory"
    ):
        load_config(tmp_path)


def test_non_utf8_file_names_the_path(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_bytes(b'name = "\xff"\n')
    with pytest.raises(ConfigError, match=r"robot\.toml: not UTF-8"):
        load_config(str(path))


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ('name = "x"\nbackend = = "sim"\n', "line 2"),
        ("[can]\n[can]\n", "line 2"),
        ('name = "x"\n\nsteering = [\n', "line 3"),
    ],
    ids=["bad-value", "duplicate-table", "unterminated"],
)
def test_bad_toml_names_the_file_and_line(tmp_path: Path, text: str, line: str) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    assert str(path) in str(caught.value)
    assert line in str(caught.value)


def test_config_error_is_a_value_error() -> None:
    with pytest.raises(ValueError, match=r"rc\.baud"):
        parse_config("[rc]\nbaud = 9600")


# --- the loader's own account of its keys (`read_schema`, `bywire verify --draw-robots`) --------


@pytest.mark.parametrize("path", [SIM, ALBERT], ids=["sim", "albert"])
def test_the_schema_names_every_typed_key_of_a_file_with_the_range_the_loader_checks(
    path: Path,
) -> None:
    from bywire.config.limits import TOLERANCE_NORM  # noqa: PLC0415
    from bywire.config.loader import read_schema  # noqa: PLC0415

    text = path.read_text()
    schema = {".".join(read.parts): read for read in read_schema(text, str(path))}
    tolerance = schema["monitors.steering_tolerance_norm"]
    assert (tolerance.kind, tolerance.allowed, tolerance.value) == ("number", TOLERANCE_NORM, 0.15)
    assert schema["supervisor.debounce_frames"].allowed == range(2, 51)
    assert schema["rc.mode_switch.positions_raw"].count == 3
    assert schema["backend"].allowed == ("sim", "linux")
    # every key of the file is in it but the raw strings its readers check themselves (a GPIO
    # line's name, a CPU list, a file path, web origins): none is a number or a flag
    data = tomllib.loads(text)
    unrecorded = [key for key in leaf_keys(data) if key not in schema]
    assert unrecorded
    for key in unrecorded:
        value: object = data
        for part in key.split("."):
            assert isinstance(value, dict)
            value = value[part]
        assert isinstance(value, str | list), key
        assert all(isinstance(item, str) for item in value), key


def test_the_schema_records_the_value_a_file_gives_or_the_default() -> None:
    from bywire.config.loader import read_schema  # noqa: PLC0415

    schema = {
        ".".join(r.parts): r.value for r in read_schema("[monitors]\nhydro_min_duty = 0.15\n")
    }
    assert schema["monitors.hydro_min_duty"] == 0.15
    assert schema["monitors.steering_tolerance_norm"] == 0.15  # absent: the default
    with pytest.raises(ConfigError, match="hydro_min_duty"):
        read_schema("[monitors]\nhydro_min_duty = 3.0\n")


# --- the E-stop input: wired, "none", or not stated (then the default line, never "no E-stop")


def test_a_file_without_the_estop_key_reads_the_default_line_and_says_it_was_not_stated() -> None:
    estop = parse_config('backend = "linux"\ngpio_chip = "chip7"\n').estop
    assert estop.line == GpioLine("chip7", "ESTOP")  # not None: a missing key is no "none"
    assert not estop.stated
    assert "NOT STATED" in estop.summary()
    assert 'line = "none"' in estop.summary()


def test_none_says_there_is_no_estop_and_a_line_says_where_it_is() -> None:
    assert parse_config('[estop]\nline = "none"\n').estop.line is None
    assert parse_config('[estop]\nline = "none"\n').estop.summary().startswith("E-stop: none")
    wired = parse_config('[estop]\nline = { chip = "/dev/gpiochip3", line = 4 }\n').estop
    assert wired.line == GpioLine("/dev/gpiochip3", 4)
    assert wired.stated
    assert "NOT STATED" not in wired.summary()


@pytest.mark.parametrize(
    ("value", "reason"),
    [
        ("true", 'a table { chip = ..., line = ... }, or "none", got a boolean'),
        ("1.5", 'or "none", got a float'),
        ("4096", "out of range; allowed a line name (string) or an offset (integer 0..1023)"),
        ('""', "expected a line name (string)"),
    ],
)
def test_a_bad_estop_line_is_refused_naming_the_key_and_the_allowed_forms(
    value: str, reason: str
) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_config(f"[estop]\nline = {value}\n")
    assert f"estop.line = {value}:" in str(caught.value)
    assert reason in str(caught.value)


def test_an_estop_on_an_output_line_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"drive\.motors_enable and estop\.line both use GPIO"):
        parse_config('[estop]\nline = "MOTORS_ENABLE"\n')


def test_the_estop_round_trips_through_describe() -> None:
    for text in ('[estop]\nline = "none"\n', "[estop]\nline = 7\n", ""):
        config = parse_config(text)
        assert parse_config(describe(config)) == config
