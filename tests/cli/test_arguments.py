"""Shared argument types: durations are positive numbers of seconds."""

from __future__ import annotations

import argparse

import pytest

from bywire.cli.arguments import positive_seconds


@pytest.mark.parametrize(("text", "seconds"), [("1", 1.0), ("0.25", 0.25), ("60", 60.0)])
def test_positive_durations_are_accepted(text: str, seconds: float) -> None:
    assert positive_seconds(text) == seconds


@pytest.mark.parametrize("text", ["0", "-1", "nan", "ten", ""])
def test_other_durations_are_refused_naming_the_value(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError, match="seconds > 0"):
        positive_seconds(text)
