"""The kernel tier's tests run only inside its guest kernel (tests/kernel/run boots it).

Elsewhere they are deselected, with one line at the end of the run saying how many and how to
run them: these tests and the conformance suite's kernel rigs (which, run on their own outside
the guest, skip with the same line)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.kernel.guest import SKIP_REASON, in_tier

HERE = Path(__file__).resolve().parent
_left_out: list[pytest.Item] = []


def _needs_the_kernel(item: pytest.Item) -> bool:
    if item.path.is_relative_to(HERE):
        return True
    callspec = getattr(item, "callspec", None)
    return callspec is not None and str(callspec.params.get("rig", "")).startswith("kernel-")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if in_tier():
        return
    _left_out[:] = [item for item in items if _needs_the_kernel(item)]
    if _left_out:
        config.hook.pytest_deselected(items=_left_out)
        items[:] = [item for item in items if not _needs_the_kernel(item)]


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    if _left_out:
        terminalreporter.write_line(f"{len(_left_out)} tests deselected: {SKIP_REASON}")
