"""Teleop's send clock: a thread of its own that sends every period on absolute deadlines, and
the gaps it measured between sends.

The commands went out from the terminal program's event loop, so a busy or slow screen delayed
them: under CPU load the gaps reached 98 ms idle and 142-220 ms with keys held, past the robot's
100 ms CAN timeout (three latched STOPs in a minute of driving, issue 32). This thread does only
the sending (`send`: read the reports, send the frames, advance the state), never the screen; the
screen shows what `SendGaps` measured.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable

from bywire.background import OWNER

GAPS_KEPT = 500  # ten seconds at 50 Hz


class SendGaps:
    """The intervals between consecutive sends (s), the last `GAPS_KEPT` of them."""

    def __init__(self, period_s: float, late_s: float) -> None:
        """`late_s`: a gap this long lets the robot's command timeout expire (counted)."""
        self.period_s = period_s
        self.late_s = late_s
        self._gaps: deque[float] = deque(maxlen=GAPS_KEPT)
        self._last_s: float | None = None
        self.late = 0
        self.worst_s = 0.0
        self._lock = threading.Lock()

    def sent(self, now_s: float) -> None:
        with self._lock:
            if self._last_s is not None:
                gap_s = now_s - self._last_s
                self._gaps.append(gap_s)
                self.worst_s = max(self.worst_s, gap_s)
                self.late += gap_s >= self.late_s
            self._last_s = now_s

    def line(self) -> str:
        """'send period 20.0 ms, jitter max 1.2 ms (last 10 s), worst gap 21.2 ms, 0 late'."""
        with self._lock:
            gaps = list(self._gaps)
            worst_s, late = self.worst_s, self.late
        if not gaps:
            return "send period: no period measured yet"
        mean_s = sum(gaps) / len(gaps)
        jitter_s = max(abs(gap - self.period_s) for gap in gaps)
        return (
            f"send period {mean_s * 1000:.1f} ms, jitter max {jitter_s * 1000:.1f} ms"
            f" (last {len(gaps)}), worst gap {worst_s * 1000:.0f} ms,"
            f" {late} gap(s) ≥ {self.late_s * 1000:.0f} ms (the robot's timeout)"
        )


class PeriodicSender:
    """Calls `send()` every `period_s` from a daemon thread, on absolute deadlines (a late
    period is sent at once, missed ones are skipped, never sent in a burst)."""

    def __init__(
        self,
        send: Callable[[], None],
        period_s: float,
        monotonic: Callable[[], float] = time.monotonic,
    ) -> None:
        self._send = send
        self._period_s = period_s
        self._monotonic = monotonic
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> PeriodicSender:
        self._thread = OWNER.thread(self._run, name="bywire-teleop-send", stop=self._stop.set)
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        next_s = self._monotonic()
        while not self._stop.is_set():
            now_s = self._monotonic()
            if now_s < next_s:
                self._stop.wait(next_s - now_s)
                continue
            self._send()
            next_s += self._period_s
            if next_s <= self._monotonic():  # fell behind: the next period from now
                next_s = self._monotonic() + self._period_s
