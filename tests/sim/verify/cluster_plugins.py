"""Plugins of the cluster tests. Worker plugins, installed by a test's own client on every worker
(the replacements of dead ones too), make a campaign crash its worker process or make a worker
claim another build of bywire; a scheduler plugin counts what each worker is given. Nothing in
bywire reads them: the only way in is a test's `register_plugin` or `add_plugin`."""

from __future__ import annotations

import logging
import os
import threading
from pathlib import Path

from dask.typing import Key
from distributed import LocalCluster, Scheduler, SchedulerPlugin, Worker, WorkerPlugin

from bywire.config import RobotConfig
from bywire.sim.verify import cluster
from bywire.sim.verify.engine import CampaignJob, Outcome, run_indexed

CRASH_STATUS = 70


class CrashAt(WorkerPlugin):
    """Campaign `index` ends its worker process (os._exit, as a segfault or the OOM killer
    would) before it runs: every time, or with `once` the first time only (the file `once`
    records that it happened, across the workers' processes)."""

    def __init__(self, index: int, once: Path | None = None) -> None:
        self.index = index
        self.once = once

    def setup(self, worker: Worker) -> None:
        real = run_indexed
        index, once = self.index, self.once

        def crashing(robot: RobotConfig, job: CampaignJob, at: int) -> Outcome:
            if at == index and (once is None or _first(once)):
                os._exit(CRASH_STATUS)
            return real(robot, job, at)

        vars(cluster)["run_indexed"] = crashing  # the name run_batch calls


def _first(marker: Path) -> bool:
    try:
        os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return False
    return True


class OtherBuild(WorkerPlugin):
    """The worker runs another build of bywire (as a machine not upgraded would)."""

    def setup(self, worker: Worker) -> None:
        vars(cluster)["build_id"] = lambda: "0.0.9+0123456789ab"


class Crowding(SchedulerPlugin):
    """Records, each time the scheduler gives a batch to a worker, how many batches that worker
    is then processing: a death counts against every one of them."""

    def __init__(self, scheduler: Scheduler) -> None:
        self.held: list[int] = []
        self.scheduler = scheduler

    def transition(self, key: Key, start: str, finish: str, *args: object, **kw: object) -> None:
        if finish == "processing":
            worker = self.scheduler.tasks[key].processing_on
            if worker is not None:
                self.held.append(len(worker.processing))


class FirstResult(SchedulerPlugin):
    """Set once the scheduler holds the first batch's result: the run is under way."""

    def __init__(self) -> None:
        self.held = threading.Event()

    def transition(self, key: Key, start: str, finish: str, *args: object, **kw: object) -> None:
        if finish == "memory":
            self.held.set()


def their_cluster(threads: int = 1) -> LocalCluster:
    """A cluster as a user runs one (`dask scheduler`, one `dask worker --nthreads THREADS`),
    its scheduler in this process, on 127.0.0.1."""
    return LocalCluster(  # type: ignore[no-untyped-call]
        n_workers=1,
        threads_per_worker=threads,
        host=cluster.LOOPBACK,
        dashboard_address=None,
        # its HTTP routes on a free port, not 8787: two at once (a second worker's) warned
        scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
        silence_logs=logging.ERROR,
    )
