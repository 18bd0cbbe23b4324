"""What `bywire verify --cluster local` installs on each of its worker processes (the ones that
replace a dead worker too). Imported only with Dask distributed installed (`bywire[cluster]`)."""

from __future__ import annotations

import signal
import threading

from distributed import Worker, WorkerPlugin


class LeaveInterruptToTheParent(WorkerPlugin):
    """A local worker ignores Ctrl-C, which the terminal sends to every process of the group:
    `bywire verify` shuts the cluster down, and no worker prints a traceback of its own (as the
    process pool's workers do). Never installed on the workers of a cluster the user runs."""

    def setup(self, worker: Worker) -> None:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
