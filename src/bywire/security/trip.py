"""The controller's trip counter: the high half of every freshness value it accepts, moved on and
persisted at each start before anything is accepted (AUTOSAR SecOC's trip counter, with the
controller as freshness master; docs/SECURITY.md).

A frame is accepted only in the trip it was made for, so a frame recorded before this start
(replay after a restart) or made while the controller was down (pre-play) never verifies.
That holds only while the trip counter never repeats, so the file is trusted only when it is
whole, this key's and in range: a missing, damaged or foreign file refuses the start (one line
naming `bywire keys reset-freshness`, a deliberate act that keeps the old file); a trip counter
near its end too (a new key starts again at 0).

Each start moves the counter on by a random step of 1..TRIP_STEP, not by 1: a file rolled back to
an older copy (a restored backup or disk image) then starts a trip that was, with probability at
least 1 - 2/TRIP_STEP, never used before, and the senders, which never go back to a lower trip,
say so. The 32-bit counter lasts for 2**32 / TRIP_STEP * 2 = 131,072 starts on average.
"""

from __future__ import annotations

import datetime
import os
import random
from pathlib import Path

from bywire.errors import ConfigError
from bywire.protocol.secoc import MAX_TRIP, SecocKey
from bywire.security.state_file import Problem, StateFileError, read_state, whole, write_state

KIND = "bywire trip counter 1"
WHAT = "freshness file"
TRIP_STEP = 1 << 16  # the largest step at a start
MAX_LOADED_TRIP = MAX_TRIP - TRIP_STEP  # above it the next start could pass 32 bits
IN_MEMORY_TRIP = 1  # the trip of a controller without a file (a simulated run): always the same
RECOVERY = "bywire keys reset-freshness --config ROBOT.toml"


class FreshnessError(ConfigError):
    """The freshness file cannot be trusted: the controller does not start."""


def read_trip(path: Path, key: SecocKey, recovery: str = RECOVERY) -> int:
    """The trip counter in `path` for `key`; FreshnessError (one line, naming what to do)."""
    try:
        fields = read_state(path, key, KIND, WHAT)
    except StateFileError as error:
        advice = _advice(error.problem, recovery)
        raise FreshnessError(f"{error}: refusing to start; {advice}") from None
    trip = whole(fields.get("trip"), 0, MAX_TRIP) if set(fields) == {"trip"} else None
    if trip is None:
        raise FreshnessError(
            f"{path}: {WHAT} holds {sorted(fields)!r} where a trip counter 0..{MAX_TRIP} goes"
            f" (damaged): refusing to start; {_advice(Problem.DAMAGED, recovery)}"
        )
    if trip > MAX_LOADED_TRIP:
        raise FreshnessError(
            f"{path}: trip counter {trip} is too near its end ({MAX_LOADED_TRIP} at most):"
            " this key's freshness is used up; make a new key (bywire keys new), name it in"
            f" [security] key_file, then {recovery}"
        )
    return trip


def start_trip(
    path: Path, key: SecocKey, rng: random.Random | None = None, recovery: str = RECOVERY
) -> int:
    """This start's trip counter, on the disk before it is returned (nothing may be accepted
    that the next start could accept again). FreshnessError when the file cannot be trusted or
    written."""
    trip = read_trip(path, key, recovery) + (rng or random.SystemRandom()).randint(1, TRIP_STEP)
    try:
        write_state(path, key, KIND, {"trip": trip})
    except OSError as error:
        raise FreshnessError(
            f"{path}: cannot write the {WHAT}: {error.strerror or error}: refusing to start (the"
            " trip counter must be on the disk before a command is accepted)"
        ) from None
    return trip


def reset_trip(path: Path, key: SecocKey, after_trip: int, now: datetime.datetime) -> Path | None:
    """Start the key's trip counter afresh at `after_trip` (the next start is above it). The old
    file, whatever it holds, is kept beside it under a dated name (returned; None if there was
    none). ConfigError when a good file of this key names a higher trip (that would reopen its
    trips to replay), or when the files cannot be written."""
    if not 0 <= after_trip <= MAX_LOADED_TRIP:
        raise ConfigError(f"--trip {after_trip}: allowed 0..{MAX_LOADED_TRIP}")
    try:
        kept = read_trip(path, key)
    except FreshnessError:
        kept = None
    if kept is not None and kept > after_trip:
        raise ConfigError(
            f"{path}: a good {WHAT} of this key at trip {kept}: starting at {after_trip} would"
            f" reopen trips {after_trip + 1}..{kept} to replays; give --trip {kept} or more"
        )
    old = None
    if os.path.lexists(path):
        old = path.with_name(f"{path.name}.replaced-{now:%Y%m%dT%H%M%SZ}")
        if os.path.lexists(old):
            raise ConfigError(f"{old}: exists already; wait a second and run it again")
        os.rename(path, old)
    try:
        write_state(path, key, KIND, {"trip": after_trip})
    except OSError as error:
        raise ConfigError(f"{path}: cannot write the {WHAT}: {error.strerror or error}") from None
    _give_to_folder_owner(path)
    return old


def _advice(problem: Problem, recovery: str) -> str:
    if problem is Problem.FOREIGN:
        return f"if the key is new, {recovery}"
    used = "for a key never used before; for one that was, make a new key first (bywire keys new)"
    if problem is Problem.MISSING:
        return f"{recovery} makes one ({used})"
    return f"{recovery} replaces it, keeping this one ({used}, or give --trip N)"


def _give_to_folder_owner(path: Path) -> None:
    """Run as root on the robot, the file goes to the state folder's owner (the service's user),
    who must read and write it; elsewhere it is the caller's already."""
    if os.geteuid() != 0:
        return
    folder = path.parent.stat()
    os.chown(path, folder.st_uid, folder.st_gid)
