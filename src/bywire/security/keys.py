"""Key files: made with a random 128-bit key, mode 0600, and refused when others may touch them.

The checks are OpenSSH's for a private key (and sshd's StrictModes): a key file must be owned by
the user running bywire or by root, and neither group nor others may read or write it; nor may
they write the folder that holds it (they could put another file in its place); a
configuration file (which names the key and can switch authentication off) has the same owner
rule and must not be writable by group or others. Each refusal is one line naming the file, what
is wrong and the command that fixes it. The key's bytes leave this module only inside a
`SecocKey`, whose repr shows its check value, never the key.
"""

from __future__ import annotations

import os
import pwd
import secrets
import stat
from pathlib import Path

from bywire.errors import ConfigError
from bywire.protocol.secoc import KEY_BYTES, SecocKey
from bywire.textfile import read_text

KEY_FILE_MODE = 0o600
GROUP_OTHER_WRITE = stat.S_IWGRP | stat.S_IWOTH
GROUP_OTHER_ACCESS = stat.S_IRWXG | stat.S_IRWXO
KEY_FILE_LIMIT_BYTES = 4096  # 33 bytes of hex and a newline


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
    """The key in `path`, once its owner, mode and folder are private; ConfigError naming the
    problem otherwise."""
    check_private(path, GROUP_OTHER_ACCESS, "key file")
    check_folder(path, "key file")
    text = read_text(path, "key file", KEY_FILE_LIMIT_BYTES).strip()
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
    """Refuse a configuration file (it names the key) that another user owns, or that group or
    others can write."""
    check_private(path, GROUP_OTHER_WRITE, "configuration file")


def check_private(path: Path, forbidden: int, what: str) -> None:
    """Refuse `path` when another user owns it or its mode has any bit of `forbidden`."""
    try:
        status = path.stat()
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such {what}") from None
    except OSError as error:
        raise ConfigError(f"{path}: cannot stat {what}: {error.strerror}") from None
    _check_owner(path, status, what)
    mode = status.st_mode
    if mode & forbidden:
        allowed = "0600" if forbidden == GROUP_OTHER_ACCESS else "0644 or stricter"
        raise ConfigError(
            f"{path}: {what} has mode {stat.S_IMODE(mode):04o}: group or others may "
            f"{'read or write' if forbidden == GROUP_OTHER_ACCESS else 'write'} it;"
            f" refused (chmod {allowed[:4]} {path})"
        )


def check_folder(path: Path, what: str) -> None:
    """Refuse a file in a folder that another user owns or that group or others may write: they
    could replace the file with their own."""
    folder = path.resolve().parent
    try:
        status = folder.stat()
    except OSError as error:
        raise ConfigError(f"{folder}: cannot stat the {what}'s folder: {error.strerror}") from None
    _check_owner(folder, status, f"{what}'s folder")
    if status.st_mode & GROUP_OTHER_WRITE:
        raise ConfigError(
            f"{path}: the {what}'s folder {folder} has mode {stat.S_IMODE(status.st_mode):04o}:"
            f" group or others may put another file in its place; refused (chmod go-w {folder},"
            " or keep the key in a private folder such as /etc/bywire)"
        )


def _check_owner(path: Path, status: os.stat_result, what: str) -> None:
    user = os.geteuid()
    if status.st_uid not in (user, 0):
        raise ConfigError(
            f"{path}: {what} is owned by {_user_name(status.st_uid)}, not by the user running"
            f" bywire ({_user_name(user)}) or root; refused (chown {_user_name(user)} {path})"
        )


def _user_name(uid: int) -> str:
    try:
        return pwd.getpwuid(uid).pw_name
    except KeyError:
        return f"uid {uid}"
