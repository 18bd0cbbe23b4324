"""`bywire keys`: the key of authenticated commands, and the controller's freshness file.

`new FILE` writes a random 128-bit key, mode 0600; an existing file is never overwritten (exit 2).
The key itself is never printed: only its check value, which tells two copies apart (the
controller's and the sender's) without revealing it.

`reset-freshness --config ROBOT.toml [--trip N]` starts the controller's trip counter afresh: the
one deliberate way past a freshness file that is missing (a new robot), damaged, another key's,
or rolled back. The old file is kept beside it under a dated name, never deleted.
"""

from __future__ import annotations

import argparse
import datetime
from pathlib import Path

from bywire.config import load_config
from bywire.errors import ConfigError
from bywire.security.keys import new_key_file, read_key_file
from bywire.security.trip import reset_trip


def configure(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    new = actions.add_parser(
        "new",
        help="write a random 128-bit key (hex) to FILE, mode 0600; never overwrites",
        description="Write a random AES-128 key for SecOC-authenticated commands to FILE "
        "(mode 0600; an existing file is refused). Name it as [security] key_file on the "
        "controller and give the same file to every sender (docs/SECURITY.md).",
    )
    new.add_argument("file", type=Path, metavar="FILE", help="the key file to create")
    reset = actions.add_parser(
        "reset-freshness",
        help="start the controller's trip counter afresh (keeps the old freshness file)",
        description="Write a new freshness file (the controller's trip counter) for the robot "
        "file's [security] key_file and freshness_file. Needed once on a new robot, and after "
        "the controller refused to start because the file was missing, damaged or another "
        "key's. The old file is kept beside it (FILE.replaced-DATE). With a key that was used "
        "before, frames recorded in trips up to --trip could be replayed: make a new key "
        "first (bywire keys new), or give --trip the highest trip the robot announced (a "
        "sender that saw it names it). Run it as the service's user, or as root (the file "
        "then goes to the state folder's owner).",
    )
    reset.add_argument(
        "--config", type=Path, required=True, metavar="ROBOT.toml", help="the robot file"
    )
    reset.add_argument(
        "--trip",
        type=int,
        default=0,
        metavar="N",
        help="the trip counter to start above (default 0: right for a new key)",
    )


def run(args: argparse.Namespace) -> int:
    if args.action == "new":
        key = new_key_file(args.file)
        print(f"{args.file}: new 128-bit key, mode 0600, check value {key.check_value}")
        return 0
    return _reset_freshness(args.config, args.trip)


def _reset_freshness(config_path: Path, trip: int) -> int:
    security = load_config(config_path).security
    if security.key_file is None or security.freshness_file is None:
        raise ConfigError(
            f"{config_path}: [security] names no key_file and freshness_file: nothing to reset"
        )
    key = read_key_file(Path(security.key_file))
    path = Path(security.freshness_file)
    now = datetime.datetime.now(datetime.UTC)
    kept = reset_trip(path, key, trip, now)
    print(
        f"{path}: trip counter of key {key.check_value} starts above {trip}"
        + ("" if kept is None else f"; the old file is kept as {kept}")
    )
    return 0
