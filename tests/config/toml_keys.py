"""Test helper: the dotted leaf keys of a nested TOML-like dict, in file order."""

from __future__ import annotations

from collections.abc import Mapping


def leaf_keys(table: Mapping[str, object], prefix: str = "") -> list[str]:
    """["can.interface", "rc.steering.channel", ...]: every key whose value is not a table."""
    keys: list[str] = []
    for key, value in table.items():
        if isinstance(value, Mapping):
            keys += leaf_keys(value, f"{prefix}{key}.")
        else:
            keys.append(f"{prefix}{key}")
    return keys
