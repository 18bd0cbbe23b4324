"""Input validity: invalid until first seen, exact timeout boundary, no future stamps."""

from __future__ import annotations

import pytest

from bywire.control.validity import Stamped, age_s, fresh


def test_never_seen_is_invalid() -> None:
    assert fresh(None, now=10.0, timeout_s=0.1) is None
    assert age_s(None, 10.0) is None


@pytest.mark.parametrize(
    ("now", "usable"),
    [(1.0, True), (1.0625, True), (1.125, True), (1.1250001, False), (5.0, False), (0.999, False)],
)
def test_timeout_boundary_is_inclusive(now: float, usable: bool) -> None:
    slot = Stamped("command", received_at=1.0)
    # 0.125 is exact in binary, so the boundary itself is tested, not a rounding error
    assert (fresh(slot, now, timeout_s=0.125) == "command") is usable


def test_age_is_measured_from_arrival() -> None:
    assert age_s(Stamped(1, received_at=2.0), 2.25) == pytest.approx(0.25)
