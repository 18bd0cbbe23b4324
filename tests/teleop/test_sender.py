"""Teleop's send clock: the gaps between sends as the screen shows them, and a thread that sends
every period on absolute deadlines (issue 32, defect 4)."""

from __future__ import annotations

import threading
import time

from bywire.teleop.sender import PeriodicSender, SendGaps


def test_the_gaps_line_gives_period_jitter_worst_gap_and_late_gaps() -> None:
    gaps = SendGaps(period_s=0.020, late_s=0.100)
    assert gaps.line() == "send period: no period measured yet"
    for now_s in (0.0, 0.020, 0.041, 0.061, 0.211):
        gaps.sent(now_s)
    assert (gaps.late, round(gaps.worst_s, 3)) == (1, 0.150)
    assert gaps.line() == (
        "send period 52.8 ms, jitter max 130.0 ms (last 4), worst gap 150 ms,"
        " 1 gap(s) ≥ 100 ms (the robot's timeout)"
    )


def test_the_sender_sends_from_its_own_thread_until_stopped() -> None:
    senders: list[str] = []
    enough = threading.Event()

    def send() -> None:
        senders.append(threading.current_thread().name)
        if len(senders) == 3:
            enough.set()

    sender = PeriodicSender(send, 0.005).start()
    assert enough.wait(30.0)
    sender.stop()
    count = len(senders)
    assert set(senders) == {"bywire-teleop-send"}
    time.sleep(0.03)
    assert len(senders) == count  # nothing after stop()
