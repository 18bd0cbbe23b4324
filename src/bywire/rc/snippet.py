"""The suggestion as TOML to paste into the robot file: whole `[rc.*]` tables, refusals as
comments.

Each suggested stick or switch is written as its whole table (the file's channel, `reverse` and
deadband kept, the suggested values in place), laid out as `bywire config check` writes it, so
that it replaces the table in the robot file instead of defining it twice (which TOML refuses).
A stick or switch without a suggestion gets a comment saying why, and no table: the file's own
stays.
"""

from __future__ import annotations

from dataclasses import replace

from bywire.config import RobotConfig, as_dict
from bywire.config.render import table_text
from bywire.rc.suggestion import Suggestion


def suggested_config(config: RobotConfig, suggestion: Suggestion) -> RobotConfig:
    """`config` with the suggested calibration in its `[rc]` section."""
    mapping = suggestion.mapping(config.rc.mapping)
    return replace(config, rc=replace(config.rc, mapping=mapping))


def snippet_text(config: RobotConfig, suggestion: Suggestion, *, origin: str, seen_on: str) -> str:
    """The TOML text: a header saying where it comes from, a comment per refusal, the tables."""
    lines = [
        f"# bywire rc: RC calibration for {origin} (robot {config.name!r}), seen on {seen_on}.",
    ]
    if suggestion.suggested:
        lines.append(
            "# Replace these tables in the robot file, then check it: bywire config check FILE"
        )
    lines += [
        f"# rc.{refusal.name}: not suggested: {refusal.reason}" for refusal in suggestion.refusals
    ]
    tables = as_dict(suggested_config(config, suggestion))["rc"]
    assert isinstance(tables, dict)
    for item in suggestion.suggested:
        lines.extend(("", table_text(f"rc.{item.name}", tables[item.name]).rstrip("\n")))
    return "\n".join(lines) + "\n"
