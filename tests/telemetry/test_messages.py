"""Every message the feed builds is valid against its topic's JSON Schema, fields and units."""

from __future__ import annotations

import json

import pytest
from jsonschema import Draft202012Validator

from bywire.telemetry.capture import CanCapture, Capture, StateCapture
from bywire.telemetry.messages import message
from bywire.telemetry.schemas import CAN_TOPIC, EVENTS_TOPIC, SCHEMAS, STATE_TOPIC
from tests.telemetry.conftest import course_captures


@pytest.fixture(scope="module")
def captures() -> list[Capture]:
    """The course up to CAN driving at full set-point (23.1 s), with every bus frame."""
    return course_captures(24.0)


def test_every_schema_is_a_valid_json_schema_with_a_title() -> None:
    for schema in SCHEMAS.values():
        Draft202012Validator.check_schema(schema)
        assert schema["title"].startswith("bywire.")


def test_every_message_of_a_run_matches_its_topics_schema(captures: list[Capture]) -> None:
    validators = {topic: Draft202012Validator(schema) for topic, schema in SCHEMAS.items()}
    seen: set[str] = set()
    for capture in captures:
        topic, body = message(capture)
        errors = [error.message for error in validators[topic].iter_errors(body)]
        assert errors == [], (topic, body)
        json.dumps(body, allow_nan=False)  # plain JSON: no NaN, no bytes, no enums
        seen.add(topic)
    assert seen == {STATE_TOPIC, EVENTS_TOPIC, CAN_TOPIC}


def test_inputs_not_yet_seen_are_null_and_seen_ones_have_their_age(
    captures: list[Capture],
) -> None:
    states = [message(c)[1] for c in captures if isinstance(c, StateCapture)]
    assert states[0]["inputs"]["can_movement_age_s"] is None
    in_can = [s for s in states if s["mode"] == "CAN"]
    assert in_can
    assert all(0.0 <= s["inputs"]["can_movement_age_s"] <= 0.1 for s in in_can)
    assert {s["setpoint_source"] for s in in_can} == {"can"}
    # Once the throttle has ramped up, the set-point is the higher-level computer's command.
    driving = [s for s in in_can if s["setpoint"]["throttle_norm"] == 0.4]
    assert driving
    assert all(s["setpoint"] == s["inputs"]["can_movement"] for s in driving)


def test_a_can_message_carries_the_frame_bytes() -> None:
    topic, body = message(CanCapture(1.5, 0x123, bytes([1, 0xAB]), "hlc"))
    assert topic == CAN_TOPIC
    assert body == {
        "time_s": 1.5,
        "arbitration_id": 0x123,
        "dlc": 2,
        "data_bytes": [1, 0xAB],
        "data_hex": "01ab",
        "sender": "hlc",
    }
