"""Fixtures shared by the tests of the command-line programs."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.hal.linux.pty_rc import PtyRcLine


@pytest.fixture
def line(tmp_path: Path) -> Iterator[PtyRcLine]:
    """The RC receiver on a pty, sending, its transmitter's switch at STOP in gear forward."""
    rc = PtyRcLine.at_rest(tmp_path / "ttyRC")
    yield rc
    rc.close()
