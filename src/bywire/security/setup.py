"""Building both ends from the configuration: the controller's receiver, a simulated sender's
signer, and the ephemeral key a simulated run uses when the configuration names none."""

from __future__ import annotations

import random
import secrets
from pathlib import Path

from bywire.config.security import SecuritySection
from bywire.errors import ConfigError
from bywire.protocol import dbc
from bywire.protocol.secoc import KEY_BYTES, SecocKey
from bywire.security.freshness import FreshnessStore
from bywire.security.keys import read_key_file
from bywire.security.session import SecocReceiver, SecocSigner


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


def controller_receiver(security: SecuritySection, key: SecocKey) -> SecocReceiver:
    """The CAN reader's verifier, its freshness persisted when the configuration names a file.

    The file is written once here, unchanged, before the loop runs: a state directory that
    cannot be written is an error at start-up, not at the first command.
    """
    path = None if security.freshness_file is None else Path(security.freshness_file)
    store = FreshnessStore(key, path, security.freshness_block)
    try:
        store.save()
    except OSError as error:
        raise ConfigError(f"{path}: cannot write freshness file: {error.strerror}") from None
    return SecocReceiver(key, store, dbc.command_ids(), security.pairing_window_s)


def sender_signer(key: SecocKey, path: Path | None = None, block: int = 32) -> SecocSigner:
    """A sender's signer; its freshness persisted in `path` (None: in memory)."""
    return SecocSigner(key, FreshnessStore(key, path, block))
