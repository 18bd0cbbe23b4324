"""The simulation's clocks, metered: CPU time spent inside ``wait_until`` is the simulator's.

The controller's loop calls ``wait_until`` between its passes; every simulated device, the bus
and the benchmark's own timers run inside it, the controller never does. So the process's CPU
time minus the CPU time spent in there is the controller's own share (port drivers included).
"""

from __future__ import annotations

import time

from bywire.hal.simulated.clock import RealtimeClock, VirtualClock


class _CpuMeter(VirtualClock):
    """Adds up the process CPU time spent in ``wait_until``, where only the simulator runs."""

    waiting_cpu_s: float = 0.0  # the first += makes it the instance's own

    def wait_until(self, deadline_s: float) -> None:
        started_s = time.process_time()
        try:
            super().wait_until(deadline_s)
        finally:
            self.waiting_cpu_s += time.process_time() - started_s


class MeteredVirtualClock(_CpuMeter):
    """A VirtualClock that adds up the process CPU time spent in ``wait_until``."""


class MeteredRealtimeClock(_CpuMeter, RealtimeClock):
    """A RealtimeClock that adds up the process CPU time spent in ``wait_until`` (sleep is free)."""


MeteredClock = MeteredVirtualClock | MeteredRealtimeClock
