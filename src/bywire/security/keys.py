"""Key files: made with a random 128-bit key, mode 0600, and refused when others may touch them.

The checks are sshd's StrictModes: a key file that group or others can read or write, or a
configuration file (which names the key and can switch authentication off) that they can write,
is refused at load with one line naming the file, its mode and the fix. The key's bytes leave
this module only inside a `SecocKey`, whose repr shows its check value, never the key.
"""

from __future__ import annotations

import os
import secrets
import stat
from pathlib import Path

from bywire.errors import ConfigError
from bywire.protocol.secoc import KEY_BYTES, SecocKey

KEY_FILE_MODE = 0o600
GROUP_OTHER_WRITE = stat.S_IWGRP | stat.S_IWOTH
GROUP_OTHER_ACCESS = stat.S_IRWXG | stat.S_IRWXO


def new_key_file(path: Path) -> SecocKey:
    """Write a random key to `path` (hex, one line), mode 0600; never overwrites a file."""
    secret = secrets.token_bytes(KEY_BYTES)
    try:
        descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, KEY_FILE_MODE)
    except FileExistsError as error:
        raise ConfigError(
            f"{path}: exists; a key is never overwritten (remove it first)"
        ) from error
    except OSError as error:
        raise ConfigError(f"{path}: cannot create key file: {error.strerror}") from error
    with os.fdopen(descriptor, "w", encoding="ascii") as file:
        os.fchmod(file.fileno(), KEY_FILE_MODE)  # whatever the umask
        file.write(secret.hex() + "\n")
    return SecocKey(secret)


def read_key_file(path: Path) -> SecocKey:
    """The key in `path`, once its mode is private; ConfigError naming the problem otherwise."""
    check_private(path, GROUP_OTHER_ACCESS, "key file")
    try:
        text = path.read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError) as error:
        raise ConfigError(f"{path}: cannot read key file: {error}") from None
    try:
        secret = bytes.fromhex(text)
    except ValueError:
        secret = b""
    if len(secret) != KEY_BYTES:
        raise ConfigError(
            f"{path}: not a key file: expected {2 * KEY_BYTES} hex digits on one line"
            " (bywire keys new FILE writes one)"
        )
    return SecocKey(secret)


def check_configuration_file(path: Path) -> None:
    """Refuse a configuration file (it names the key) that group or others can write."""
    check_private(path, GROUP_OTHER_WRITE, "configuration file")


def check_private(path: Path, forbidden: int, what: str) -> None:
    """Refuse `path` when its mode has any bit of `forbidden` (StrictModes)."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such {what}") from None
    except OSError as error:
        raise ConfigError(f"{path}: cannot stat {what}: {error.strerror}") from None
    if mode & forbidden:
        allowed = "0600" if forbidden == GROUP_OTHER_ACCESS else "0644 or stricter"
        raise ConfigError(
            f"{path}: {what} has mode {stat.S_IMODE(mode):04o}: group or others may "
            f"{'read or write' if forbidden == GROUP_OTHER_ACCESS else 'write'} it;"
            f" refused (chmod {allowed[:4]} {path})"
        )
