"""Shared test settings: hypothesis runs derandomised on CI and never fails on wall-clock time;
every test fails that leaves a thread or a child process of ours running (`tests/leaks.py`)."""

import os
from collections.abc import Iterator

import pytest
from hypothesis import settings

from tests.compiled import CompiledAwareMonkeyPatch
from tests.leaks import no_leaks

__all__ = ["no_leaks"]  # autouse: every test runs under the leak check (issue 42)

# The machines are shared and noisy: a property must fail on its logic, never on a slow example.
settings.register_profile("default", deadline=None)
settings.register_profile("ci", deadline=None, derandomize=True, print_blob=True)
# A search, not a gate: `pytest --hypothesis-profile=long tests/...`, ten times CI's examples.
settings.register_profile("long", deadline=None, max_examples=1000, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "default")


@pytest.fixture
def monkeypatch() -> Iterator[pytest.MonkeyPatch]:
    """pytest's own, except that on the compiled build a test that replaces compiled code is
    skipped, saying so (`tests/compiled.py`)."""
    patch = CompiledAwareMonkeyPatch()
    yield patch
    patch.undo()


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Under `pytest -n auto` (a pytest-xdist worker collects), the tests marked `long` first,
    each kind in its order: the workers take tests in collection order, and a long test taken
    last would run on alone. The README's serial command keeps the files' order, the one its
    real-time tests were proven in."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        items.sort(key=lambda item: item.get_closest_marker("long") is None)
