"""The CAN input stage checked exhaustively: every reachable state of one command message ×
every abstract frame (unreadable; an intact one with every counter, the same, ahead or behind,
asking for request A, B or something out of range; on time or after a gap), breadth-first from
the first frame, every invariant on every transition.

Beside the stage's state the search keeps its own record of what it sent with each counter of
the sequence followed (None where the sequence skipped one), from what it sent and the rules,
not from the stage's fields, so I8 judges the stage from outside: a counter the sequence passed,
then from the bus asking anything but what the bus carried with it, is a second sender (issue
41, finding 9); the same again, a stale frame that moves nothing.

Times are kept relative to the step and capped where the rules stop telling them apart, and
counters relative to the last one, so the reachable states are finite; the counter is cut to
MODULUS values (with MAX_STEP and the history derived from it as the stage derives them) and
the trust window to WINDOW frames (the rules do not depend on their sizes), which keeps them
few. Then teeth: the rules of dce19d3's reader, and 9002ac3's stage, put back are each found.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import replace
from typing import cast

import pytest

from bywire.control import input_stage
from bywire.control.input_stage import Decoded, MessageState, Verdict, message_step
from bywire.model import Gear, MovementCommand, same_request, with_counter

PERIOD_S, TIMEOUT_S = 0.020, 0.100
WINDOW = 3
MODULUS, MAX_STEP = 6, 2  # a smaller counter (the stage's rules scale): every offset tried
HISTORY = (MODULUS + MAX_STEP) // 2  # as the stage derives it
A = MovementCommand(0.0, 0.2, 0.0, Gear.FORWARD, 0)
B = MovementCommand(1.0, 0.8, 0.0, Gear.FORWARD, 0)
REQUESTS: tuple[MovementCommand | None, ...] = (A, B, None)  # None: intact, out of range
OFFSETS = tuple(range(MODULUS))  # every counter: the same, ahead and behind
WAITS_S = (PERIOD_S, PERIOD_S + TIMEOUT_S)  # arrival times judge nothing but a gap
Frame = tuple[Decoded, float, int | None]  # the frame, the wait before it, its counter offset

Record = tuple[MovementCommand | None, ...]
"""What the search sent with the counter followed and each before it (None: skipped), newest
first, HISTORY at the most"""
Invariant = Callable[[MessageState, Frame, MessageState, Verdict, Record], bool]
"""(before, the frame, after, its verdict, the search's record before it) -> holds"""


def _frames() -> list[Frame]:
    frames: list[Frame] = [(Decoded(readable=False), wait, None) for wait in WAITS_S]
    for offset in OFFSETS:
        for request in REQUESTS:
            for wait in WAITS_S:
                frames.append((Decoded(True, offset, request), wait, offset))
    return frames


def _at(state: MessageState, frame: Frame) -> Decoded:
    """The frame with its counter relative to the state's (0 before the first)."""
    decoded, _, offset = frame
    if offset is None or decoded.counter is None:
        return decoded
    counter = ((state.counter or 0) + offset) % MODULUS
    command = None if decoded.command is None else with_counter(decoded.command, counter)
    return Decoded(True, counter, command)


def _relative(time_s: float | None, now: float, cap_s: float) -> float | None:
    return None if time_s is None else max(round(time_s - now, 6), -cap_s)


def _canonical(state: MessageState, now: float) -> MessageState:
    """The state as seen from `now`: times relative and capped, the counter rotated to 0."""
    seen = tuple(None if seen is None else with_counter(seen, 0) for seen in state.seen)
    return MessageState(
        counter=None if state.counter is None else 0,
        seen=seen,
        last_at=_relative(state.last_at, now, TIMEOUT_S + PERIOD_S),
        lost=min(state.lost, MAX_STEP - 1),  # more lost frames allow no further step
        window=state.window,
        untrusted=state.untrusted,
    )


def _never_accepts_the_counter_just_used(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, _record: Record
) -> bool:
    gap = before.last_at is None or frame[1] - before.last_at > TIMEOUT_S  # it starts afresh
    return not (verdict.used and frame[2] == 0 and before.counter is not None and not gap)


def _unreadable_changes_nothing_but_the_lost_count(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, _record: Record
) -> bool:
    if frame[0].readable:
        return True
    return replace(after, lost=before.lost) == before and after.lost == before.lost + 1


def _identical_repeats_cost_no_trust(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, record: Record
) -> bool:
    decoded, wait_s, offset = frame
    gap = before.last_at is None or wait_s - before.last_at > TIMEOUT_S
    identical = (
        offset == 0
        and bool(record)
        and record[0] is not None
        and decoded.command is not None
        and same_request(decoded.command, record[0])
    )
    if not identical or gap:
        return True
    return after.window == before.window and after.untrusted == before.untrusted


def _nothing_used_while_untrusted(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, _record: Record
) -> bool:
    return not (verdict.used and after.untrusted)


def _a_conflict_distrusts_at_once(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, _record: Record
) -> bool:
    return verdict is not Verdict.CONFLICT or after.untrusted


def _trust_returns_only_after_a_clean_window(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, _record: Record
) -> bool:
    regained = before.untrusted and not after.untrusted
    return not regained or (len(after.window) == WINDOW and not any(after.window))


def _misses_distrust(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, _record: Record
) -> bool:
    return sum(after.window) < input_stage.COUNTER_MISS_LIMIT or after.untrusted


def _gap(before: MessageState, wait_s: float) -> bool:
    """The frame starts the sequence afresh (the first, or after a gap)."""
    return before.last_at is None or wait_s - before.last_at > TIMEOUT_S


def _passed(before: MessageState, frame: Frame, record: Record) -> int | None:
    """How far back the frame's counter is, when the search's record says the sequence passed
    it (and it is not within the unreadable frames' allowance ahead); else None."""
    _, wait_s, offset = frame
    if offset is None or not record or _gap(before, wait_s) or _allowed(before, offset):
        return None
    back = (-offset) % MODULUS
    return back if back < len(record) else None


def _allowed(before: MessageState, offset: int) -> bool:
    """Within the steps the unreadable frames allow (and the history bounds)."""
    return 1 <= offset <= min(1 + before.lost, MAX_STEP)


def _a_passed_counter_from_the_bus_is_a_second_sender_or_stale(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, record: Record
) -> bool:
    back = _passed(before, frame, record)
    if back is None or back == 0 or not frame[0].readable:
        return True
    carried, request = record[back], frame[0].command
    moved = after.counter != before.counter or after.seen != before.seen
    if carried is not None and request is not None and same_request(request, carried):
        return verdict is Verdict.COUNTER and not moved  # stale: a miss, never followed back
    return verdict is Verdict.CONFLICT and after.untrusted and not moved


def _a_frame_the_lost_ones_explain_costs_no_trust(
    before: MessageState, frame: Frame, after: MessageState, verdict: Verdict, _record: Record
) -> bool:
    """The guard: an honest sender's damaged frames (unreadable) then its next one."""
    decoded, wait_s, offset = frame
    if before.counter is None or offset is None or decoded.command is None or _gap(before, wait_s):
        return True
    if not _allowed(before, offset):
        return True
    return verdict in (Verdict.ACCEPTED, Verdict.UNTRUSTED) and not after.window[-1]


INVARIANTS: dict[str, Invariant] = {
    "I1 the counter just used is never accepted (but after a gap)": (
        _never_accepts_the_counter_just_used
    ),
    "I2 an unreadable frame moves nothing": _unreadable_changes_nothing_but_the_lost_count,
    "I3 an identical repeat costs no trust": _identical_repeats_cost_no_trust,
    "I4 nothing is used while untrusted": _nothing_used_while_untrusted,
    "I5 a conflict distrusts at once": _a_conflict_distrusts_at_once,
    "I6 trust returns only after a clean window": _trust_returns_only_after_a_clean_window,
    "I7 misses distrust": _misses_distrust,
    "I8 a counter passed, then from the bus, is a second sender (the same again: stale)": (
        _a_passed_counter_from_the_bus_is_a_second_sender_or_stale
    ),
    "I9 a frame the unreadable ones explain costs no trust": (
        _a_frame_the_lost_ones_explain_costs_no_trust
    ),
}


def _record_after(before: MessageState, frame: Frame, record: Record) -> Record:
    """The search's own record once the frame is judged: by the rules, not the stage's state."""
    decoded, wait_s, offset = frame
    if not decoded.readable or offset is None:
        return record  # says nothing of the sequence
    request = cast(MovementCommand | None, decoded.command)
    request = None if request is None else replace(request, counter=0)
    if not record or _gap(before, wait_s):
        return (request,)  # the sequence starts
    if _passed(before, frame, record) is not None:
        return record  # a passed counter moves nothing
    return (request, *(None,) * (offset - 1), *record)[:HISTORY]


Step = Callable[[MessageState, Decoded, float, float], tuple[MessageState, Verdict]]


def explore(
    step: Step = message_step, max_violations: int = 1
) -> tuple[int, int, list[tuple[str, list[Frame]]]]:
    """(states, transitions, violations with their shortest frame sequence)."""
    frames = _frames()
    start: tuple[MessageState, Record] = (MessageState(), ())
    seen = {start}
    paths: dict[tuple[MessageState, Record], list[Frame]] = {start: []}
    queue, transitions, violations = deque([start]), 0, []
    while queue:
        state, record = node = queue.popleft()
        for frame in frames:
            decoded = _at(state, frame)
            after, verdict = step(state, decoded, frame[1], TIMEOUT_S)
            transitions += 1
            sent = (decoded, frame[1], frame[2])
            for name, holds in INVARIANTS.items():
                if not holds(state, sent, after, verdict, record):
                    violations.append((name, [*paths[node], frame]))
                    if len(violations) >= max_violations:
                        return len(seen), transitions, violations
            key = (_canonical(after, frame[1]), _record_after(state, sent, record))
            if key not in seen:
                seen.add(key)
                paths[key] = [*paths[node], frame]
                queue.append(key)
    return len(seen), transitions, violations


@pytest.fixture(autouse=True)
def _small_window(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(input_stage, "COUNTER_WINDOW", WINDOW)
    monkeypatch.setattr(input_stage, "COUNTER_MODULUS", MODULUS)
    monkeypatch.setattr(input_stage, "MAX_STEP", MAX_STEP)
    monkeypatch.setattr(input_stage, "COUNTER_HISTORY", HISTORY)


@pytest.mark.long
def test_every_reachable_state_keeps_every_invariant(capsys: pytest.CaptureFixture[str]) -> None:
    states, transitions, violations = explore()
    with capsys.disabled():
        print(
            f"\ninput stage exhaustive check: {states} states, {len(_frames())} frames, "
            f"{transitions} transitions, {len(INVARIANTS)} invariants on each"
        )
    assert violations == []
    assert states > 500


# --- teeth: dce19d3's reader rules, put back, are found ----------------------------------------


def _found(monkeypatch: pytest.MonkeyPatch, name: str, fake: object) -> set[str]:
    monkeypatch.setattr(input_stage, name, fake)
    return {violation for violation, _ in explore(max_violations=1)[2]}


def test_an_unreadable_frame_that_resets_the_sequence_is_found() -> None:
    def resetting(
        state: MessageState, frame: Decoded, at: float, timeout: float
    ) -> tuple[MessageState, Verdict]:
        if not frame.readable:  # dce19d3: "the next frame starts it afresh"
            return MessageState(window=state.window, untrusted=state.untrusted), Verdict.UNREADABLE
        return message_step(state, frame, at, timeout)

    found = {violation for violation, _ in explore(resetting, max_violations=1)[2]}
    assert "I2 an unreadable frame moves nothing" in found


def test_a_repeat_judged_as_a_counter_miss_is_found(monkeypatch: pytest.MonkeyPatch) -> None:
    def old_repeat(state: MessageState, frame: Decoded) -> Verdict:
        if state.counter is not None and frame.counter == state.counter:
            return Verdict.COUNTER  # dce19d3: every repeat a miss, whatever it asked
        return original(state, frame)

    original = input_stage._judged
    found = _found(monkeypatch, "_judged", old_repeat)
    assert "I3 an identical repeat costs no trust" in found


def test_a_stage_that_remembers_only_the_counter_followed_is_found(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Issue 41, finding 9: 9002ac3's stage judged a counter behind the one followed as a stale
    one, a miss, whatever the bus had carried with it: a forgery that skipped the counter after
    an unreadable frame was taken, and the computer's own skipped counter cost one miss."""
    monkeypatch.setattr(
        input_stage, "_passed", lambda state, counter: 0 if counter == state.counter else None
    )
    found = {violation for violation, _ in explore(max_violations=1)[2]}
    assert any(violation.startswith("I8") for violation in found)


def test_a_history_of_only_half_the_counter_is_found(monkeypatch: pytest.MonkeyPatch) -> None:
    """A history of half the counter (a first design of the fix) is found: a counter the
    sequence passed is then taken for one ahead, a miss, and one far miss pushes a skipped
    counter out of memory."""
    monkeypatch.setattr(input_stage, "COUNTER_HISTORY", MODULUS // 2)
    found = {violation for violation, _ in explore(max_violations=1)[2]}
    assert any(violation.startswith("I8") for violation in found)
