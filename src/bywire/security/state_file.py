"""The state files of authenticated commands: JSON that names its kind and its key and carries a
check over its content, read strictly and written atomically.

    {"check": "3f9c...", "key_check": "A1B2C3", "kind": "bywire trip counter 1", "trip": 7}

The check is the first 8 bytes of the key's CMAC over the rest of the file (canonical JSON), so a
changed digit, a truncated or hand-edited file, or one made for another key is told apart from a
good one; each is refused with its own reason (the caller adds what to do). Every other check is
the caller's: which fields there are and the range of every number.
"""

from __future__ import annotations

import enum
import hmac
import json
import os
from pathlib import Path
from typing import Any

from bywire.atomic_file import remove_leftovers, write_atomically
from bywire.errors import ConfigError
from bywire.protocol.secoc import SecocKey
from bywire.textfile import read_text

LIMIT_BYTES = 64 << 10  # a state file is under 1 KiB
CHECK_BYTES = 8
_CHECK_LABEL = b"bywire state file\x00"


class Problem(enum.Enum):
    """Why a state file cannot be used."""

    MISSING = "missing"
    DAMAGED = "damaged"
    FOREIGN = "foreign"


class StateFileError(ConfigError):
    """A state file that is missing, damaged or another key's; `problem` says which."""

    def __init__(self, path: Path, problem: Problem, detail: str) -> None:
        self.path = path
        self.problem = problem
        super().__init__(f"{path}: {detail}")


def state_bytes(key: SecocKey, kind: str, fields: dict[str, Any]) -> bytes:
    """The file's content: `fields`, the kind, the key's check value and the check."""
    body = {**fields, "kind": kind, "key_check": key.check_value}
    return (json.dumps({**body, "check": _check(key, body)}, sort_keys=True) + "\n").encode()


def write_state(path: Path, key: SecocKey, kind: str, fields: dict[str, Any]) -> None:
    """Replace the file atomically (mode 0600); OSError when it cannot be written."""
    remove_leftovers(path)
    write_atomically(path, state_bytes(key, kind, fields))


def read_state(path: Path, key: SecocKey, kind: str, what: str) -> dict[str, Any]:
    """The fields of a good file of this kind and key; StateFileError naming the problem."""
    if not os.path.lexists(path):
        raise StateFileError(path, Problem.MISSING, f"no {what}")
    try:
        text = read_text(path, what, LIMIT_BYTES)
    except ConfigError as error:
        raise StateFileError(path, Problem.DAMAGED, _without_path(error, path)) from None
    try:
        document = json.loads(text)
    except (ValueError, RecursionError):
        raise StateFileError(path, Problem.DAMAGED, f"{what} is not JSON (damaged)") from None
    if not isinstance(document, dict) or document.get("kind") != kind:
        raise StateFileError(path, Problem.DAMAGED, f"not a {what} (damaged, or another file)")
    key_check = document.get("key_check")
    if key_check != key.check_value:
        raise StateFileError(
            path,
            Problem.FOREIGN,
            f"{what} of another key (check value {str(key_check)[:12]!r}, the key's is"
            f" {key.check_value})",
        )
    check = document.pop("check", None)
    if not isinstance(check, str) or not hmac.compare_digest(check, _check(key, document)):
        raise StateFileError(path, Problem.DAMAGED, f"{what} fails its check (damaged or edited)")
    del document["kind"], document["key_check"]
    return document


def _check(key: SecocKey, body: dict[str, Any]) -> str:
    canonical = json.dumps(body, sort_keys=True, separators=(",", ":")).encode()
    return key.cmac(_CHECK_LABEL + canonical)[:CHECK_BYTES].hex()


def _without_path(error: ConfigError, path: Path) -> str:
    return str(error).removeprefix(f"{path}: ")


def whole(value: object, low: int, high: int) -> int | None:
    """`value` if it is an integer (not a bool) in low..high, else None."""
    if isinstance(value, int) and not isinstance(value, bool) and low <= value <= high:
        return value
    return None
