"""`bywire config check`: a good file prints every resolved value (loadable again), a bad one is
exit 2 with the key and the allowed range."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

from bywire.cli.main import main
from bywire.command_table import COMMANDS
from bywire.config import as_dict, load_config, parse_config

ROOT = Path(__file__).resolve().parents[2]
ALBERT = ROOT / "config" / "albert.toml"


def _check(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(["config", "check", *argv])
    return status, out.getvalue(), err.getvalue()


def test_a_valid_file_prints_what_it_resolved_to() -> None:
    status, out, err = _check(str(ALBERT))
    assert (status, err) == (0, "")
    assert out.splitlines()[0] == f"# {ALBERT}: valid; robot 'albert', backend 'linux'"
    assert parse_config(out) == load_config(ALBERT)
    assert 'interface = "socketcan"' in out


def test_the_receive_check_of_each_can_command_is_shown_with_its_own_timeout(
    tmp_path: Path,
) -> None:
    robot = tmp_path / "robot.toml"
    robot.write_text("[timeouts.can_message_timeout_s]\nLightsCommand = 0.5\n")
    status, out, _ = _check(str(robot))
    assert status == 0
    checks = [line for line in out.splitlines() if line.startswith("#   ") and "0x" in line]
    assert len(checks) == len(COMMANDS)  # one line per command row, the shipped ones first
    assert checks[:3] == [
        "#   ControlCommand 0x100: 3 bytes, counter mod 16, CRC-8 in the last byte,"
        " every 20 ms, lost after 100 ms",
        "#   MovementCommand 0x101: 8 bytes, counter mod 16, CRC-8 in the last byte,"
        " every 20 ms, lost after 100 ms",
        "#   LightsCommand 0x102: 3 bytes, counter mod 16, CRC-8 in the last byte,"
        " every 20 ms, lost after 500 ms",
    ]


def test_the_switch_bands_are_shown(tmp_path: Path) -> None:
    robot = tmp_path / "robot.toml"
    robot.write_text("[rc.mode_switch]\npositions_raw = [1250, 1500, 1750]\nband_raw = 80\n")
    status, out, _ = _check(str(robot))
    assert status == 0
    assert (
        "#   mode_switch (channel 6): STOP 1170..1330, RC 1420..1580, CAN 1670..1830 µs;"
        " hysteresis ±25 µs"
    ) in out.splitlines()


def test_switch_bands_that_would_touch_are_refused_with_the_largest_that_fits(
    tmp_path: Path,
) -> None:
    robot = tmp_path / "robot.toml"
    robot.write_text("[rc.mode_switch]\npositions_raw = [1250, 1500, 1750]\n")
    status, _, err = _check(str(robot))
    assert status == 2
    assert "rc.mode_switch: positions [1250, 1500, 1750] µs are 250 µs apart" in err
    assert "set band_raw to 99 or less" in err


def test_json_gives_the_same_values() -> None:
    status, out, _ = _check(str(ALBERT), "--json")
    assert status == 0
    resolved = json.loads(out)
    losses = resolved.pop("loss_distances")
    assert resolved.pop("speed_limit")[0].startswith("speed limit 2 m/s")
    assert resolved == json.loads(json.dumps(as_dict(load_config(ALBERT))))
    assert [(row["key"], row["distance_m"]) for row in losses] == [
        ("timeouts.rc_timeout_s", 0.33),  # (0.1 s + one 10 ms period) at 3 m/s
        ("timeouts.can_command_timeout_s", 0.33),
        ("timeouts.watchdog_s", 0.6),
    ]


def test_the_text_states_what_each_timeout_buys(tmp_path: Path) -> None:
    robot = tmp_path / "robot.toml"
    robot.write_text(
        'backend = "linux"\n[timeouts]\nrc_timeout_s = 1.0\nwatchdog_s = 1.0\n'
        "[timeouts.can_message_timeout_s]\nMovementCommand = 0.5\n"
    )
    status, out, _ = _check(str(robot))
    assert status == 0
    assert (
        "an unplugged RC receiver (timeouts.rc_timeout_s = 1 s): the stop begins within 1.01 s,"
        " after up to 3.03 m at 3 m/s"
    ) in out
    assert "(timeouts.can_message_timeout_s.MovementCommand = 0.5 s)" in out
    assert "a stalled control loop (timeouts.watchdog_s = 1 s): the stop begins within 1 s" in out


def test_a_bad_value_names_the_key_and_range(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('backend = "linux"\n[drive.dac]\naddress = 0x50\n')
    status, out, err = _check(str(bad))
    assert (status, out) == (2, "")
    assert err.startswith("bywire config: error: ")
    assert "drive.dac.address = 0x50" in err
    assert "0x4C..0x4F" in err


def test_a_missing_file_is_one_line(tmp_path: Path) -> None:
    status, _, err = _check(str(tmp_path / "none.toml"))
    assert status == 2
    assert err.count("\n") == 1
    assert "no such configuration file" in err


def test_the_stop_promises_are_shown_and_a_declared_longer_one_says_so(tmp_path: Path) -> None:
    status, out, _ = _check(str(ALBERT))
    assert status == 0
    assert (
        "#   the operator's switch moves to STOP -> the spring brake within the IBUS frame that"
        " carries it + 0.01 s = 0.0177 s"
    ) in out.splitlines()
    bench = tmp_path / "bench.toml"
    bench.write_text("[timeouts]\nstop_response_s = 0.06\npass_budget_s = 0.05\n")
    status, out, _ = _check(str(bench))
    assert status == 0
    declared = [line for line in out.splitlines() if "declared by timeouts.stop_response_s" in line]
    assert len(declared) == 3


def test_the_check_says_whether_an_estop_is_wired(tmp_path: Path) -> None:
    status, out, _ = _check(str(ALBERT))
    assert status == 0
    assert '# E-stop: none (the robot file says [estop] line = "none")' in out.splitlines()
    silent = tmp_path / "silent.toml"
    silent.write_text('name = "silent"\n')
    status, out, _ = _check(str(silent))
    assert status == 0
    assert "# E-stop: wired on line 'ESTOP' of gpiochip0 (normally closed): NOT STATED" in out


def test_the_speed_limit_and_how_it_is_enforced_are_shown(tmp_path: Path) -> None:
    status, out, _ = _check(str(ALBERT))
    assert status == 0
    assert "#   speed limit 2 m/s (7.2 km/h), both directions, RC and CAN mode" in out
    assert "brake begins above 2.20 m/s and is full at 2.40 m/s" in out
    assert (
        "a throttle ceiling of 0.300, derived from the limit and the vehicle's calibration" in out
    )
    assert "the 'linux' backend opens no wheel-speed sensor: the ceiling applies" in out
    raised = tmp_path / "raised.toml"
    raised.write_text(ALBERT.read_text().replace("max_speed_mps = 2.0 ", "max_speed_mps = 2.9 "))
    status, out, _ = _check(str(raised), "--json")
    assert status == 0
    shown = json.loads(out)
    assert shown["limits"] == {"max_speed_mps": 2.9}
    assert "speed limit 2.9 m/s (10.4 km/h)" in shown["speed_limit"][0]
    assert "throttle ceiling of 0.811" in shown["speed_limit"][2]  # the calibration's last


def test_how_a_controlled_stop_ends_and_its_standstill_hold_are_shown(tmp_path: Path) -> None:
    status, out, _ = _check(str(ALBERT))
    assert status == 0
    assert "until the wheel speed reads standstill (at most 0.05 m/s), and 2.5 s at most" in out
    assert "from above 0.1 m/s is held 0.30 s first: a wheel sensor dying below 0.45 m/s" in out
    assert "regeneration (1.50 m/s²) stops a robot rolling that fast within the hold" in out
    weaker = tmp_path / "weaker.toml"
    weaker.write_text("[drive]\nmax_regen_volts = 4.0\n")
    status, out, _ = _check(str(weaker))
    assert status == 0
    assert "is held 0.38 s first" in out


def test_a_limit_out_of_range_is_refused_naming_the_key_and_range(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[limits]\nmax_speed_mps = 31\n")
    status, out, err = _check(str(bad))
    assert (status, out) == (2, "")
    assert "limits.max_speed_mps = 31: out of range; allowed 0.1..30 m/s" in err
