"""The outbox: the loop's only hand-over to the writer; full means drop the oldest, counted."""

from __future__ import annotations

import threading
import time

import pytest

from bywire.telemetry.outbox import Outbox

LIMIT_S = 30.0  # generous: a limit on waiting, never a timing assertion


def test_a_full_outbox_drops_its_oldest_items_and_counts_them() -> None:
    outbox: Outbox[int] = Outbox(3)
    for item in range(5):
        outbox.put(item)
    assert outbox.take(0.0) == [2, 3, 4]
    assert (outbox.dropped, outbox.put_count) == (2, 5)


def test_take_returns_everything_queued_in_order_and_empties_the_outbox() -> None:
    outbox: Outbox[str] = Outbox(10)
    outbox.put("a")
    outbox.put("b")
    assert outbox.take(0.0) == ["a", "b"]
    assert outbox.take(0.0) == []
    assert len(outbox) == 0


def test_a_put_into_a_stuck_consumers_outbox_returns_at_once() -> None:
    """Nobody takes: the producer still finishes, holding only the newest `capacity` items."""
    outbox: Outbox[int] = Outbox(8)
    done = threading.Event()

    def produce() -> None:
        for item in range(10_000):
            outbox.put(item)
        done.set()

    threading.Thread(target=produce, daemon=True).start()
    assert done.wait(LIMIT_S)
    assert outbox.take(0.0) == list(range(9_992, 10_000))
    assert outbox.dropped == 9_992


def test_waiting_when_full_loses_nothing() -> None:
    """Virtual time's outbox: the producer waits for room, so the consumer gets every item."""
    outbox: Outbox[int] = Outbox(2, wait_when_full=True)

    def produce() -> None:
        for item in range(1_000):
            outbox.put(item)

    threading.Thread(target=produce, daemon=True).start()
    received: list[int] = []
    deadline = time.monotonic() + LIMIT_S
    while len(received) < 1_000 and time.monotonic() < deadline:
        received += outbox.take(0.1)
    assert received == list(range(1_000))
    assert outbox.dropped == 0


def test_close_wakes_a_waiting_consumer() -> None:
    outbox: Outbox[int] = Outbox(2)
    taken: list[list[int]] = []
    consumer = threading.Thread(target=lambda: taken.append(outbox.take(3600.0)), daemon=True)
    consumer.start()
    outbox.close()
    consumer.join(LIMIT_S)
    assert taken == [[]]
    assert outbox.closed


def test_an_outbox_holds_at_least_one_item() -> None:
    with pytest.raises(ValueError, match="capacity"):
        Outbox(0)


def test_take_ready_takes_at_most_its_limit_oldest_first_without_waiting() -> None:
    outbox: Outbox[int] = Outbox(10)
    assert outbox.take_ready(4) == []  # empty: returns at once
    for item in range(6):
        outbox.put(item)
    assert outbox.take_ready(4) == [0, 1, 2, 3]
    assert outbox.take_ready(4) == [4, 5]
    assert len(outbox) == 0
