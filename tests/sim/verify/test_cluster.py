"""`bywire verify --cluster`'s engine on a local Dask cluster bound to 127.0.0.1: outcomes come
back in index order, equal to the campaigns run here; a worker killed mid-batch costs nothing but
a retry; a campaign that kills its worker twice is a finding with its seed and index, the rest of
its batch still run; a worker of another build is refused; a cluster that loses its last worker
stops the run, saying so, where it waited for ever."""

from __future__ import annotations

import contextlib
import socket
import threading
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import dask
import pytest
from distributed import Client

from bywire.config import default_sim_config
from bywire.sim.verify.cluster import (
    ALLOWED_FAILURES,
    LOCAL,
    LOOPBACK,
    ClusterError,
    ClusterLostError,
    batch_size,
    cluster_client,
    cluster_outcomes,
    robot_hash,
)
from bywire.sim.verify.engine import CampaignJob, Crash, Outcome, run_indexed
from tests.sim.verify.cluster_plugins import (
    CrashAt,
    Crowding,
    FirstResult,
    OtherBuild,
    their_cluster,
)

JOB = CampaignJob(seed=5, campaign_s=2.0)
BUDGET = 6  # 2 workers: batches of 2 campaigns, [0, 2), [2, 4), [4, 6)


@pytest.fixture
def client() -> Iterator[Client]:
    """A fresh local cluster of 2 worker processes (a test's plugins stay in its workers)."""
    with cluster_client(LOCAL, 2) as started:
        yield started


def _run(client: Client) -> list[Outcome | Crash]:
    return list(
        cluster_outcomes(
            client,
            robot=default_sim_config(),
            robot_file_hash=robot_hash("sim"),
            job=JOB,
            budget=BUDGET,
            until=None,
        )
    )


def _here(indices: range) -> list[Outcome]:
    robot = default_sim_config()
    return [run_indexed(robot, JOB, index) for index in indices]


def test_the_scheduler_and_every_worker_listen_on_loopback_only(client: Client) -> None:
    info = client.scheduler_info(n_workers=-1)
    addresses = [info["address"], *info["workers"]]
    assert len(addresses) == 3
    assert all(address.startswith(f"tcp://{LOOPBACK}:") for address in addresses)


def test_the_outcomes_come_back_in_index_order_as_the_campaigns_run_here(client: Client) -> None:
    assert batch_size(BUDGET, 2) == 2
    assert _run(client) == _here(range(BUDGET))


def test_a_worker_killed_mid_batch_is_replaced_and_its_batch_retried(
    client: Client, tmp_path: Path
) -> None:
    killed = tmp_path / "killed"
    client.register_plugin(CrashAt(3, once=killed), name="crash-once")  # batch [2, 4), second
    outcomes = _run(client)
    assert killed.exists()  # a worker did die running campaign 3
    assert outcomes == _here(range(BUDGET))
    client.wait_for_workers(2, timeout=60)  # replaced (under load, after the run may end)
    assert len(client.scheduler_info(n_workers=-1)["workers"]) == 2


def test_a_campaign_that_kills_its_worker_twice_is_reported_with_its_seed_and_index(
    client: Client,
) -> None:
    client.register_plugin(CrashAt(4), name="crash-always")  # batch [4, 6), first
    outcomes = _run(client)
    assert outcomes[4] == Crash(seed=JOB.seed, index=4, deaths=2)
    # The batch was split down to the campaign: the one beside it in the batch still ran.
    assert [o for o in outcomes if isinstance(o, Outcome)] == _here(range(4)) + _here(range(5, 6))


def test_the_halves_of_a_killed_batch_go_out_one_per_worker_so_an_innocent_half_is_never_blamed(
    tmp_path: Path,
) -> None:
    """A scheduler the user runs (Dask's default worker-saturation 1.1 lets it give two batches
    to a one-thread worker), one worker, batches [0, 2) and [2, 3); campaign 1 kills its worker
    every time. CI once reported campaign 0 as a crash of its own, two ways: the halves of
    [0, 2) went out together, onto the one worker; and campaign 0's result, still held on the
    worker that campaign 1 killed, was computed again beside campaign 1's retry. A death counts
    against every batch its worker is processing."""
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES}),
        their_cluster() as theirs,
        cluster_client(theirs.scheduler_address, 1) as one,
    ):
        crowding = Crowding(theirs.scheduler)  # the scheduler runs in this process
        theirs.scheduler.add_plugin(crowding)
        one.register_plugin(CrashAt(1), name="crash-always")
        outcomes = list(
            cluster_outcomes(
                one,
                robot=default_sim_config(),
                robot_file_hash=robot_hash("sim"),
                job=JOB,
                budget=3,
                until=None,
            )
        )
    held = crowding.held
    assert held
    assert max(held) == 1  # never a batch waiting behind another on one worker
    assert outcomes[1] == Crash(seed=JOB.seed, index=1, deaths=2)
    assert [o for o in outcomes if isinstance(o, Outcome)] == _here(range(1)) + _here(range(2, 3))


def test_a_cluster_that_loses_its_last_worker_stops_the_run_saying_so_and_keeps_what_ran() -> None:
    """Every worker stopped mid-run (the user's `dask worker` ended, its machine gone): the
    batches out wait for a worker that never comes. The run waited for ever; it now stops once
    the cluster has been without a worker for its limit, with the outcomes already back."""
    with their_cluster() as theirs, cluster_client(theirs.scheduler_address, 1) as one:
        first_result = FirstResult()
        theirs.scheduler.add_plugin(first_result)
        outcomes = cluster_outcomes(
            one,
            robot=default_sim_config(),
            robot_file_hash=robot_hash("sim"),
            job=JOB,
            budget=40,  # batches of 8: several still to go when the worker leaves
            until=None,
            no_worker_limit_s=0.5,
        )
        got: list[Outcome | Crash] = []
        ended: list[BaseException] = []

        def drain() -> None:
            try:
                got.extend(outcomes)
            except ClusterLostError as lost:
                ended.append(lost)

        runner = threading.Thread(target=drain, daemon=True)
        runner.start()
        assert first_result.held.wait(60)
        for _ in range(600):  # until an outcome is back here (a result left on the worker
            if got:  # goes with it, to be computed again)
                break
            time.sleep(0.05)
        theirs.scale(0)  # every worker leaves
        runner.join(60)
        assert not runner.is_alive(), "the run still waits on a cluster without a worker"
    assert len(ended) == 1
    assert f"the cluster at {theirs.scheduler_address} has had no worker for 0.5 s" in str(ended[0])
    assert "dask worker" in str(ended[0])
    assert 0 < len(got) < 40
    assert got == _here(range(len(got)))  # what came back is kept, in index order


def test_a_worker_of_another_build_is_refused(client: Client) -> None:
    client.register_plugin(OtherBuild(), name="other-build")
    with pytest.raises(ClusterError, match=r"runs bywire 0\.0\.9\+0123456789ab.*mixed versions"):
        _run(client)


def test_a_local_cluster_takes_no_fixed_port_and_warns_nothing_when_8787_is_taken() -> None:
    """Dask's scheduler serves its HTTP routes on 8787 by default: a second cluster (another
    `verify --cluster local`, a user's own) found it taken and warned on the user's stderr."""
    taken = socket.socket()
    with contextlib.suppress(OSError):  # taken already: as good
        taken.bind((LOOPBACK, 8787))
        taken.listen()
    try:
        with warnings.catch_warnings(record=True) as warned:
            warnings.simplefilter("always")
            with cluster_client(LOCAL, 1) as local:
                http = local.cluster.scheduler.http_server  # type: ignore[union-attr]
                assert (http.address, http.port != 8787) == (LOOPBACK, True)
        assert [str(w.message) for w in warned if "8787" in str(w.message)] == []
    finally:
        taken.close()
