"""Building both ends from the configuration: the controller's receiver, a simulated sender's
signer, and the ephemeral key a simulated run uses when the configuration names none."""

from __future__ import annotations

import random
import secrets
from pathlib import Path

from bywire.config.security import SecuritySection
from bywire.protocol import dbc
from bywire.protocol.secoc import KEY_BYTES, SecocKey
from bywire.security.freshness import FreshnessStore
from bywire.security.keys import read_key_file
from bywire.security.session import SecocReceiver, SecocSigner
from bywire.security.trip import IN_MEMORY_TRIP, RECOVERY, start_trip


def configured_key(security: SecuritySection) -> SecocKey:
    """The key the configuration names, or a fresh random one for a simulated run without."""
    if security.key_file is None:
        return SecocKey(secrets.token_bytes(KEY_BYTES))
    return read_key_file(Path(security.key_file))


def simulated_run_key(security: SecuritySection, seed: int) -> SecocKey:
    """The key of a simulated run: the configured key file when [security] is on (the robot
    uses it), else one drawn from the simulator's seed, so that an authenticated scenario on a
    robot that does not authenticate needs no file and repeats bit for bit (its replay too)."""
    if security.enabled and security.key_file is not None:
        return read_key_file(Path(security.key_file))
    return SecocKey(random.Random(f"secoc-key-{seed}").randbytes(KEY_BYTES))


def controller_receiver(
    security: SecuritySection, key: SecocKey, config_path: str | None = None
) -> SecocReceiver:
    """The CAN reader's verifier in this start's trip: with a freshness file, the trip counter
    moved on and on the disk before this returns (FreshnessError, one line naming the
    recovery, when the file is missing, damaged, another key's, or cannot be written); without
    one (a simulated run), always the same trip in memory. `config_path`: the robot file, named
    in the recovery command."""
    trip = IN_MEMORY_TRIP
    if security.freshness_file is not None:
        recovery = RECOVERY.replace("ROBOT.toml", config_path or "ROBOT.toml")
        trip = start_trip(Path(security.freshness_file), key, recovery=recovery)
    return SecocReceiver(key, trip, dbc.command_ids(), security.pairing_window_s)


def sender_signer(key: SecocKey, path: Path | None = None, block: int = 32) -> SecocSigner:
    """A sender's signer; its freshness persisted in `path` (None: in memory). Feed it every
    frame from the controller (`SecocSigner.hear`): it signs once it has the trip counter.
    ConfigError for a damaged file or one of another key."""
    return SecocSigner(key, FreshnessStore(key, path, block))
