"""The Foxglove layout in docs/ is the generated one, and every path in it names a real field."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from bywire.telemetry.foxglove_topics import json_schemas
from bywire.telemetry.layout import layout_json
from bywire.telemetry.schemas import SCHEMAS, Schema

SHIPPED = Path(__file__).parents[2] / "docs" / "foxglove-layout.json"
PATH_KEYS = {"value", "path", "topicPath"}


def _paths(node: Any) -> Iterator[str]:
    """Every message path a panel of the layout reads."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key in PATH_KEYS and isinstance(value, str):
                yield value
            else:
                yield from _paths(value)
    elif isinstance(node, list):
        for item in node:
            yield from _paths(item)


def _field(schema: Schema, names: list[str]) -> Schema:
    """The schema of a dotted field path; KeyError if a name is not a field."""
    for name in names:
        objects = [schema, *schema.get("anyOf", [])]
        schema = next(s["properties"][name] for s in objects if name in s.get("properties", {}))
    return schema


def _resolves(path: str) -> bool:
    for topic, schema in (SCHEMAS | json_schemas()).items():
        if path == topic or path.startswith(topic + "."):
            names = path.removeprefix(topic).split(".")[1:]
            try:
                _field(schema, names)
            except StopIteration:
                return False
            return True
    return False


def test_the_shipped_layout_is_the_generated_one() -> None:
    """Regenerate with `python -m bywire.telemetry.layout > docs/foxglove-layout.json`."""
    assert SHIPPED.read_text(encoding="utf-8") == layout_json()


def test_every_path_in_the_layout_names_a_field_of_the_feed() -> None:
    paths = list(_paths(json.loads(layout_json())))
    assert len(paths) > 10
    assert [path for path in paths if not _resolves(path)] == []


@pytest.mark.parametrize(
    "path", ["/bywire/state.outputs.dac_volts", "/bywire/stat.mode", "/bywire/state.setpoint.x"]
)
def test_a_path_to_no_field_is_caught(path: str) -> None:
    assert not _resolves(path)


def test_the_layout_uses_foxglove_s_own_topics() -> None:
    """Issue 32: the shipped layout shows the decoded CAN topics, the flags by name, the
    foxglove.Log events and the simulated vehicle's pose."""
    text = layout_json()
    shipped = json.loads(text)
    paths = set(_paths(shipped))
    assert "/bywire/can/MovementCommand.throttle_norm" in paths
    assert "/bywire/flags.RC_TIMEOUT" in paths
    assert '"topicToRender": "/bywire/log"' in text
    assert '"/bywire/pose"' in text
