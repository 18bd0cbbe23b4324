"""`bywire keys new FILE`: a random 128-bit key for authenticated commands, mode 0600.

An existing file is never overwritten (exit 2). The key itself is never printed: only its check
value, which tells two copies apart (the controller's and the sender's) without revealing it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bywire.security.keys import new_key_file


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


def run(args: argparse.Namespace) -> int:
    key = new_key_file(args.file)
    print(f"{args.file}: new 128-bit key, mode 0600, check value {key.check_value}")
    return 0
