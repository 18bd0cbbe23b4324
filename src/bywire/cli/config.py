"""`bywire config check FILE`: validate a robot configuration and print what it resolved to.

The output is the whole resolved configuration as TOML (defaults filled in), which loads back to
the same values, headed by comments (whether commands are authenticated, and the receive check
of each CAN command: its DBC period and its timeout; for each input timeout and the watchdog, how
far the robot drives on at top speed before the stop begins), or as JSON with `--json` (the
latter under `loss_distances`). A bad file exits
2 with every problem, each naming its key and the allowed range; numbers that are each in range
but together break a physical deadline (`bywire.config.deadlines`) are refused the same way,
naming the deadline and the nearest safe values.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from bywire.config import RobotConfig, as_dict, describe, load_config
from bywire.config.deadlines import (
    loss_distances,
    loss_rows,
    promise_lines,
    regen_decel_mps2,
    robot_blind_spot_mps,
)
from bywire.config.reader import number_text
from bywire.config.speed_limit import enforcement
from bywire.control.stop import STANDSTILL_LIMIT_MPS
from bywire.hal.hardware import sensors_fitted
from bywire.runtime.rx_checks import rx_checks
from bywire.runtime.settings import RuntimeConfig
from bywire.security.keys import read_key_file


def configure(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    check = actions.add_parser(
        "check",
        help="validate a configuration and print every resolved value",
        description="Validate a robot configuration TOML and print every resolved value.",
    )
    check.add_argument("file", type=Path, metavar="FILE", help="robot configuration TOML")
    check.add_argument("--json", action="store_true", help="print the resolved values as JSON")


def authentication_line(config: RobotConfig) -> str:
    """Whether commands must be authenticated, and with which key (by check value only)."""
    security = config.security
    if not security.enabled or security.key_file is None:
        return "authentication: off (commands carry counter and CRC only; [security] enabled)"
    key = read_key_file(Path(security.key_file))
    return (
        f"authentication: on (SecOC profile 3, CMAC/AES-128; key {security.key_file},"
        f" check value {key.check_value})"
    )


def switch_bands(config: RobotConfig) -> list[str]:
    """One line per RC switch: each position's band (µs), and the hysteresis that holds it."""
    mapping = config.rc.mapping
    names = {
        "mode_switch": [position.name for position in mapping.mode_positions],
        "gear_switch": [position.name for position in mapping.gear_positions],
        "low_beam_switch": ["off", "on"],
        "hazard_switch": ["off", "on"],
    }
    lines = []
    for name, labels in names.items():
        switch = getattr(mapping, name)
        ordered = labels[::-1] if switch.reverse else labels
        bands = ", ".join(
            f"{label} {low}..{high}"
            for label, (low, high) in zip(
                ordered, (switch.band(i) for i in range(len(switch.positions_raw))), strict=False
            )
        )
        lines.append(
            f"{name} (channel {switch.channel}): {bands} µs; hysteresis ±{switch.hysteresis_raw} µs"
        )
    return lines


def controlled_stop_lines(config: RobotConfig) -> list[str]:
    """How a controlled stop (category 1) ends on this robot, and why a standstill is held."""
    stop = RuntimeConfig.from_robot(config).control.stop
    blind_mps = robot_blind_spot_mps(config)
    decel = stop.controlled_min_decel_mps2
    regen = regen_decel_mps2(config)
    return [
        "the drive stays powered, braking by regeneration, until the wheel speed reads"
        f" standstill (at most {number_text(stop.standstill_mps)} m/s), and"
        f" {number_text(stop.controlled_max_s)} s at most; power off at once if the robot slows"
        f" by less than {number_text(decel)} m/s²",
        f"a standstill the readings drop to from above {number_text(STANDSTILL_LIMIT_MPS)} m/s"
        f" is held {stop.standstill_hold_s:.2f} s first: a wheel sensor dying below"
        f" {blind_mps:.2f} m/s reads so, and regeneration ({regen:.2f} m/s²) stops a robot"
        " rolling that fast within the hold",
    ]


def run(args: argparse.Namespace) -> int:
    config = load_config(args.file)
    if args.json:
        speed_limit = {"speed_limit": enforcement(config.limits, config.vehicle)}
        print(
            json.dumps(
                as_dict(config) | {"loss_distances": loss_rows(config)} | speed_limit, indent=2
            )
        )
        return 0
    print(f"# {args.file}: valid; robot {config.name!r}, backend {config.backend!r}")
    print(f"# {authentication_line(config)}")
    print(f"# {config.estop.summary()}")
    print("# CAN commands received (DBC and [timeouts]):")
    for check in rx_checks(config.timeouts):
        print(f"#   {check.describe()}")
    print("# What each timeout buys: how far the robot drives on at top speed before the stop:")
    for loss in loss_distances(config):
        print(f"#   {loss}")
    print("# Speed limit (docs/SAFETY.md row 67; [limits], [vehicle] calibration):")
    for line in enforcement(config.limits, config.vehicle):
        print(f"#   {line}")
    if config.limits.max_speed_mps is not None and not sensors_fitted(config.backend):
        print(
            f"#   the {config.backend!r} backend opens no wheel-speed sensor: the ceiling applies"
        )
    print("# RC switches (a value in no band is no position: the mode switch then means STOP):")
    for line in switch_bands(config):
        print(f"#   {line}")
    print("# Controlled stop (docs/SAFETY.md row 37; [stop], [interlocks]):")
    for line in controlled_stop_lines(config):
        print(f"#   {line}")
    print("# Stop promises (docs/SAFETY.md; [timeouts] budgets are held to them):")
    for line in promise_lines(config):
        print(f"#   {line}")
    print(describe(config), end="")
    return 0
