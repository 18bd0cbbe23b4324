"""A simulated run in a background thread, with its snapshot feed: what the dashboard watches."""

from __future__ import annotations

import threading

from bywire.dashboard.feed import SnapshotFeed
from bywire.sim.runner import SimRun

STOP_TIMEOUT_S = 5.0


class LiveRun:
    """Plays `sim` in a thread of its own; `stop()` asks the controller to stop and waits for it.

    The run's own `finally` writes the safe outputs, in the controller's thread, as ever.
    """

    def __init__(self, sim: SimRun, feed: SnapshotFeed | None = None) -> None:
        self.sim = sim
        self.feed = (feed or SnapshotFeed(sim.runtime)).attach()
        self.error: BaseException | None = None
        self._stopped = False
        self._thread = threading.Thread(target=self._play, name="bywire-controller", daemon=True)

    def start(self) -> LiveRun:
        self._thread.start()
        return self

    def stop(self, timeout_s: float = STOP_TIMEOUT_S) -> bool:
        """Request the stop (safe from any thread); True when the controller has ended."""
        self._stopped = True
        self.sim.runtime.request_stop()
        if self._thread.is_alive():
            self._thread.join(timeout_s)
        return not self._thread.is_alive()

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def _play(self) -> None:
        status = "scenario ended: outputs safe"
        try:
            record = self.sim.run()
        except Exception as error:  # shown on screen, and re-raised by nobody: keep it
            self.error = error
            status = f"controller stopped on an error: {error!r}"
        else:
            failed = sum(verdict.passed is False for verdict in record.verdicts)
            if self._stopped:
                status = "stopped: outputs safe"
            elif failed:
                status += f"; {failed} expectation(s) failed"
        self.feed.observe(self.sim.world.clock.now(), force=True)
        self.feed.finish(status)
