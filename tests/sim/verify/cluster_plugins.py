"""Worker plugins of the cluster tests: installed by a test's own client on every worker (the
replacements of dead ones too), they make a campaign crash its worker process or make a worker
claim another build of bywire. Nothing in bywire reads them: the only way in is a test's
`client.register_plugin`."""

from __future__ import annotations

import os
from pathlib import Path

from distributed import Worker, WorkerPlugin

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
