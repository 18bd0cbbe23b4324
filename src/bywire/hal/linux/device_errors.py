"""OS errors of device files turned into one-line HardwareErrors that say what to do."""

from __future__ import annotations

import errno

from bywire.errors import HardwareError

RULES_HINT = "or install deploy/99-bywire.rules (docs/DEPLOY.md)"
MISSING = frozenset({errno.ENOENT, errno.ENODEV, errno.ENXIO})
DENIED = frozenset({errno.EACCES, errno.EPERM})


def device_error(
    what: str, path: str, error: OSError, *, group: str, missing: str
) -> HardwareError:
    """A HardwareError for `error` on `path`; `missing` says how to make the device appear."""
    if error.errno in MISSING or isinstance(error, FileNotFoundError):
        return HardwareError(f"{what}: {path} does not exist: {missing}")
    if error.errno in DENIED or isinstance(error, PermissionError):
        return HardwareError(
            f"{what}: permission denied on {path}: add the user to group {group}"
            f" (sudo usermod -aG {group} $USER, then log in again) {RULES_HINT}"
        )
    if error.errno == errno.EBUSY:
        return HardwareError(
            f"{what}: {path} is busy: another process or kernel driver uses it"
            " (is bywire already running?)"
        )
    return HardwareError(f"{what}: {path}: {reason(error)}")


def reason(error: BaseException) -> str:
    """The OS's words for an error, without Python's [Errno n] prefix when it has them."""
    if isinstance(error, OSError) and error.strerror:
        return error.strerror
    return str(error) or type(error).__name__
