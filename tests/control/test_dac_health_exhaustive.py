"""The DAC's health checked exhaustively: every reachable state × every abstract transfer (either
channel; a voltage below, at or above what it holds; acknowledged, refused, or landing after one
or eight budgets), breadth-first from power-up, every invariant on every transition; and teeth:
the counting rules of the past put back are found."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

import pytest

from bywire.control import dac_health
from bywire.control.dac_health import DacHealth, Transfer, dac_step

LIMIT = 3
CHANNELS = (0, 1)
VOLTS = (0.0, 2.0, 4.0)
TRANSFERS = (
    (Transfer.ACKNOWLEDGED, 1.0),
    (Transfer.FAILED, 1.0),
    (Transfer.SLOW, 1.0),
    (Transfer.SLOW, 8.0),
)
Move = tuple[int, float, Transfer, float]
Invariant = Callable[[DacHealth, Move, DacHealth], bool]


def _moves() -> list[Move]:
    return [(c, v, t, w) for c in CHANNELS for v in VOLTS for t, w in TRANSFERS]


def _lowering_failure_fails(before: DacHealth, move: Move, after: DacHealth) -> bool:
    channel, volts, transfer, _ = move
    held = before.volts(channel)
    lowering = transfer is Transfer.FAILED and held is not None and volts < held
    return not lowering or after.failing


def _a_slow_transfer_of_a_limit_fails_at_once(
    before: DacHealth, move: Move, after: DacHealth
) -> bool:
    return not (move[2] is Transfer.SLOW and move[3] >= LIMIT) or after.failing


def _escalation_clears_only_when_drained(before: DacHealth, move: Move, after: DacHealth) -> bool:
    return not (before.escalated and not after.escalated) or after.level == 0.0


def _the_level_is_bounded(before: DacHealth, move: Move, after: DacHealth) -> bool:
    return 0.0 <= after.level <= 2 * LIMIT


def _what_it_holds_changes_only_when_a_transfer_lands(
    before: DacHealth, move: Move, after: DacHealth
) -> bool:
    channel, volts, transfer, _ = move
    if transfer is Transfer.FAILED:
        return after.acknowledged == before.acknowledged
    return after.volts(channel) == volts


def _reaching_the_limit_escalates(before: DacHealth, move: Move, after: DacHealth) -> bool:
    return after.level < LIMIT or after.escalated


INVARIANTS: dict[str, Invariant] = {
    "D1 a failed lowering write is a fault": _lowering_failure_fails,
    "D2 a transfer that took the limit's budgets is a fault at once": (
        _a_slow_transfer_of_a_limit_fails_at_once
    ),
    "D3 an escalation holds until the count has drained": _escalation_clears_only_when_drained,
    "D4 the count is bounded": _the_level_is_bounded,
    "D5 a channel holds what landed, nothing else": (
        _what_it_holds_changes_only_when_a_transfer_lands
    ),
    "D6 reaching the limit escalates": _reaching_the_limit_escalates,
}


def explore(max_violations: int = 1) -> tuple[int, int, list[str]]:
    start = DacHealth()
    seen, queue, transitions, violations = {start}, deque([start]), 0, []
    while queue:
        state = queue.popleft()
        for move in _moves():
            channel, volts, transfer, weight = move
            after = dac_step(state, channel, volts, transfer, limit=LIMIT, weight=weight)
            transitions += 1
            violations += [
                name for name, holds in INVARIANTS.items() if not holds(state, move, after)
            ]
            if len(violations) >= max_violations:
                return len(seen), transitions, violations
            if after not in seen:
                seen.add(after)
                queue.append(after)
    return len(seen), transitions, violations


def test_every_reachable_state_keeps_every_invariant(capsys: pytest.CaptureFixture[str]) -> None:
    states, transitions, violations = explore()
    with capsys.disabled():
        print(f"\nDAC health exhaustive check: {states} states, {transitions} transitions")
    assert violations == []
    assert states > 100


def _alternating_escalates() -> bool:
    """Every other transfer failing (the NAK pattern consecutive counting never sees)."""
    health = DacHealth()
    for index in range(8):
        transfer = Transfer.FAILED if index % 2 == 0 else Transfer.ACKNOWLEDGED
        health = dac_step(health, 0, 2.0, transfer, limit=LIMIT)
    return health.failing


def test_every_other_transfer_failing_escalates() -> None:
    assert _alternating_escalates()


def test_teeth_consecutive_only_counting_is_found(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(dac_health, "DAC_LEAK", 1.0)  # one good write wipes the count (row 7)
    assert not _alternating_escalates()


def test_teeth_a_slow_transfer_counted_as_one_failure_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    original = dac_health.dac_step

    def one_each(
        health: DacHealth,
        channel: int,
        volts: float,
        transfer: Transfer,
        *,
        limit: int,
        weight: float = 1.0,
    ) -> DacHealth:
        return original(health, channel, volts, transfer, limit=limit, weight=1.0)

    monkeypatch.setattr("tests.control.test_dac_health_exhaustive.dac_step", one_each)
    assert "D2 a transfer that took the limit's budgets is a fault at once" in explore()[2]
