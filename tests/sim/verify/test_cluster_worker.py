"""What a local cluster's worker process sets up before it joins: it leaves Ctrl-C to the
parent (`tests/cli/test_verify.py` sends the terminal's SIGINT to a whole run)."""

from __future__ import annotations

import signal
from typing import cast

from distributed import Worker

from bywire.sim.verify.cluster_worker import LeaveInterruptToTheParent


def test_a_local_worker_process_ignores_ctrl_c() -> None:
    previous = signal.getsignal(signal.SIGINT)
    try:
        LeaveInterruptToTheParent().setup(cast(Worker, None))
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)
