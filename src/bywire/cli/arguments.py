"""Argument types the sub-commands share, so every command refuses bad values the same way."""

from __future__ import annotations

import argparse
from collections.abc import Callable


def positive_seconds(text: str) -> float:
    """A duration in seconds, > 0; argparse turns the error into one line and exit 2."""
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value > 0:  # also refuses NaN
        raise argparse.ArgumentTypeError(f"must be a number of seconds > 0, got {text!r}")
    return value


def positive_hertz(text: str) -> float:
    """A rate in hertz, > 0; argparse turns the error into one line and exit 2."""
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0 < value < float("inf"):  # also refuses NaN
        raise argparse.ArgumentTypeError(f"must be a rate in Hz > 0, got {text!r}")
    return value


def whole_number(minimum: int) -> Callable[[str], int]:
    """A whole number >= `minimum`, as an argparse type (one line and exit 2 otherwise)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be a whole number >= {minimum}, got {text!r}")
        return value

    return parse


def number_within(low: float, high: float) -> Callable[[str], float]:
    """A number in `low`…`high`, as an argparse type (one line and exit 2 otherwise)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
        if not low <= value <= high:  # also refuses NaN
            raise argparse.ArgumentTypeError(f"must be a number within {low}…{high}, got {text!r}")
        return value

    return parse


def add_snapshot_options(parser: argparse.ArgumentParser, once_s: float, prints: str) -> None:
    """`--once` and `--duration S`: listen a while, print `prints` and exit, instead of the live
    view (the listening tools' way to run from a script or a test; `snapshot_s` reads them)."""
    parser.add_argument(
        "--once", action="store_true", help=f"listen {once_s:g} s, print {prints}, exit"
    )
    parser.add_argument(
        "--duration",
        type=positive_seconds,
        metavar="S",
        help=f"listen S seconds, print {prints}, exit (exit 1 if no frame arrived)",
    )


def snapshot_s(args: argparse.Namespace, once_s: float) -> float | None:
    """How long to listen before printing (`--duration` wins over `--once`); None: live."""
    duration_s: float | None = args.duration
    return duration_s if duration_s is not None else once_s if args.once else None
