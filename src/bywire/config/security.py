"""The `[security]` table: authenticated commands (AUTOSAR SecOC, docs/SECURITY.md), off by default.

Only names files: the key's bytes are read by `bywire.security.keys` and never enter the
configuration tree, so nothing that prints or serialises the configuration can show them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from bywire.config.reader import MISSING, Interval, Table, toml_type
from bywire.security.session import DEFAULT_WINDOW_S

PAIRING_WINDOW_S = Interval(0.0005, 0.020, "s")


@dataclass(frozen=True, slots=True)
class SecuritySection:
    """Whether commands must carry a SecOC authenticator, and the files that make it work."""

    enabled: bool = False
    key_file: str | None = None  # 128-bit key, hex, mode 0600 (`bywire keys new FILE`)
    freshness_file: str | None = None  # the controller's trip counter; None: in memory
    pairing_window_s: float = DEFAULT_WINDOW_S  # command frame to its cryptographic PDU


def security_section(table: Table, backend: str) -> SecuritySection:
    default = SecuritySection()
    section = SecuritySection(
        enabled=table.flag("enabled", default.enabled),
        key_file=_path(table, "key_file"),
        freshness_file=_path(table, "freshness_file"),
        pairing_window_s=table.number(
            "pairing_window_s", default.pairing_window_s, PAIRING_WINDOW_S
        ),
    )
    if section.enabled and section.key_file is None:
        table.refuse("enabled", True, "authentication needs key_file (bywire keys new FILE)")
    if section.enabled and backend == "linux" and section.freshness_file is None:
        table.refuse(
            "enabled",
            True,
            "on the robot, authentication needs freshness_file (the trip counter a"
            " restart moves on, so that no frame made before it is accepted after it)",
        )
    table.close()
    return section


def _path(table: Table, name: str) -> str | None:
    value = table.get(name)
    if value is MISSING:
        return None
    if not isinstance(value, str) or not value.strip():
        table.refuse(name, value, f"expected a file path, got {toml_type(value)}")
        return None
    return str(Path(value))
