"""`bywire config check FILE`: validate a robot configuration and print what it resolved to.

The output is the whole resolved configuration as TOML (defaults filled in), which loads back to
the same values, headed by comments (whether commands are authenticated, and the receive check
of each CAN command: its DBC period and its timeout), or as JSON with `--json`. A bad file exits
2 with every problem, each naming its key and the allowed range. Combinations of valid numbers
that are unsafe together (see `bywire.config.hazards`) are warned about on stderr; `bywire
verify` refuses them.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from bywire.config import RobotConfig, as_dict, describe, load_config
from bywire.config.hazards import unsafe_combinations
from bywire.runtime.rx_checks import rx_checks
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


def run(args: argparse.Namespace) -> int:
    config = load_config(args.file)
    for combination in unsafe_combinations(config):
        print(f"warning: unsafe by construction: {combination}", file=sys.stderr)
    if args.json:
        print(json.dumps(as_dict(config), indent=2))
        return 0
    print(f"# {args.file}: valid; robot {config.name!r}, backend {config.backend!r}")
    print(f"# {authentication_line(config)}")
    print("# CAN commands received (DBC and [timeouts]):")
    for check in rx_checks(config.timeouts):
        print(f"#   {check.describe()}")
    print(describe(config), end="")
    return 0
