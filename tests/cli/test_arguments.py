"""Shared argument types: durations are positive numbers of seconds."""

from __future__ import annotations

import argparse

import pytest

from bywire.cli.arguments import add_snapshot_options, positive_seconds, snapshot_s, whole_number


@pytest.mark.parametrize(("text", "seconds"), [("1", 1.0), ("0.25", 0.25), ("60", 60.0)])
def test_positive_durations_are_accepted(text: str, seconds: float) -> None:
    assert positive_seconds(text) == seconds


@pytest.mark.parametrize("text", ["0", "-1", "nan", "ten", ""])
def test_other_durations_are_refused_naming_the_value(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError, match="seconds > 0"):
        positive_seconds(text)


def test_whole_numbers_are_checked_against_their_minimum() -> None:
    at_least_one = whole_number(1)
    assert at_least_one("3") == 3
    for text in ("0", "-2", "1.5", "x"):
        with pytest.raises(argparse.ArgumentTypeError, match=f"whole number >= 1, got '{text}'"):
            at_least_one(text)
    assert whole_number(0)("0") == 0


@pytest.mark.parametrize(
    ("given", "seconds"),
    [
        ([], None),
        (["--once"], 1.5),
        (["--duration", "3"], 3.0),
        (["--once", "--duration", "3"], 3.0),
    ],
    ids=["live", "once", "duration", "duration-wins"],
)
def test_the_snapshot_options_say_how_long_to_listen(
    given: list[str], seconds: float | None
) -> None:
    parser = argparse.ArgumentParser()
    add_snapshot_options(parser, 1.5, "the table")
    assert snapshot_s(parser.parse_args(given), 1.5) == seconds
    assert "listen 1.5 s, print the table, exit" in parser.format_help()
