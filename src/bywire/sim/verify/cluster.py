"""`bywire verify --cluster`: the campaigns on a Dask distributed cluster.

`--cluster tcp://HOST:8786` uses a cluster the user runs (`dask scheduler`, `dask worker`);
`--cluster local` starts one on 127.0.0.1 (worker processes, one thread each, no dashboard), and
`cluster_client` is the one place a cluster is started and stopped.

Campaigns go out in batches of consecutive indices of one seed (`Batch`); every campaign is
drawn from its seed and index alone (`engine.run_indexed`), so which worker runs it changes
nothing, and the outcomes are handed on in index order: the same `--seed` and `--budget` give the
same summary on 1, 2 or 200 workers. Every batch's result carries the build of bywire that ran it
and the hash of the robot file it ran on: a result of another build or another file is refused.

A worker that dies is replaced by its nanny and the scheduler gives its batch to another worker;
a cluster left with no worker at all for `WORKERS_TIMEOUT_S` (every `dask worker` stopped, the
machines gone) stops the run with `ClusterLostError`, where it waited for ever;
a batch whose worker died twice (`ALLOWED_FAILURES`) comes back as Dask's KilledWorker and is
split in halves, down to the campaign, and a campaign that killed its worker twice is a finding
of its own (`Crash`, with its seed and index).

What stays on the user's machine: the robot file and its loading, drawing the robot files,
shrinking a failure, finding the keys it needs and every file written; the workers only run
campaigns and send back their outcomes.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import math
import signal
import socket
import threading
import time
from collections.abc import Callable, Generator, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from importlib import resources
from typing import TYPE_CHECKING

from bywire import __version__
from bywire.build import picklable_compiled_dataclasses
from bywire.config import RobotConfig
from bywire.errors import BywireError
from bywire.sim.verify.engine import CampaignJob, Crash, Outcome, run_indexed

if TYPE_CHECKING:
    from distributed import Client, Future

LOCAL = "local"
"""`--cluster local`: a cluster of worker processes on this machine, on 127.0.0.1 only."""
LOOPBACK = "127.0.0.1"
INSTALL = "--cluster needs Dask distributed: pip install 'bywire[cluster]'"
ALLOWED_FAILURES = 1
"""A batch whose worker dies is given to another worker once; a second death makes it killed
(Dask's KilledWorker), and it is split."""
BATCH_MAX = 8
"""Campaigns in one batch at most; fewer when the budget is small for the workers."""
IN_FLIGHT_PER_WORKER = 1
"""Batches given out per worker at a time: one, so that no batch waits on a worker behind another
(a scheduler the user runs may assign a second one at its default worker-saturation 1.1), where
a crash of the first would count a death against it and could report an innocent campaign. The
next batch goes out as one comes back (the halves of a killed batch too, first): a round trip
against a batch's seconds."""
WORKERS_TIMEOUT_S = 60.0
"""How long a cluster the user runs may take to show its first worker, and how long it may be
without any during a run (a nanny replaces a dead one in seconds) before the run stops."""
WAIT_S = 1.0
"""How often a run waiting on its batches looks whether the cluster still has a worker."""
RESULT_WAIT_S = 30.0
"""How long taking a settled batch's result may take (its outcomes through the scheduler, a
tunnel perhaps) before it is taken as lost with its worker, and waited for again."""
SETTLED = ("finished", "error", "cancelled")
"""A batch's states whose result can be taken at once; a "lost" one (its result went with its
worker) is computed again, and taking it would wait for that."""
BUILD_SUFFIXES = (".py", ".dbc", ".toml")


class ClusterError(BywireError):
    """The cluster cannot be used: not installed, unreachable, or another build of bywire."""


class ClusterLostError(ClusterError):
    """The cluster lost its last worker during a run and none came back in time: the campaigns
    not run yet cannot be (those already back are kept)."""


@functools.cache
def build_id() -> str:
    """This bywire's version and a digest of its files (the code, the DBC, the packaged
    defaults and scenarios): two machines with the same id run the same campaigns the same way."""
    digest = hashlib.sha256()
    package = resources.files("bywire")
    for path in sorted(_files(package), key=lambda p: p[0]):
        digest.update(path[0].encode())
        digest.update(path[1])
    return f"{__version__}+{digest.hexdigest()[:12]}"


def _files(folder: resources.abc.Traversable, prefix: str = "") -> Iterator[tuple[str, bytes]]:
    for entry in folder.iterdir():
        name = f"{prefix}{entry.name}"
        if entry.is_dir():
            if entry.name != "__pycache__":
                yield from _files(entry, f"{name}/")
        elif entry.name.endswith(BUILD_SUFFIXES):
            yield name, entry.read_bytes()


def robot_hash(text: str) -> str:
    """The robot file's hash, as every result names it."""
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True, slots=True)
class Batch:
    """Campaigns `start` .. `stop - 1` of `job` on `robot` (the file of hash `robot_hash`)."""

    job: CampaignJob
    robot: RobotConfig
    robot_hash: str
    start: int
    stop: int


@dataclass(frozen=True, slots=True)
class BatchResult:
    """A batch's outcomes, with the build that ran them, where, and on which robot file."""

    build: str
    host: str
    robot_hash: str
    outcomes: tuple[Outcome, ...]


def run_batch(batch: Batch) -> BatchResult:
    """On a worker: run the batch's campaigns."""
    outcomes = tuple(
        run_indexed(batch.robot, batch.job, index) for index in range(batch.start, batch.stop)
    )
    picklable_compiled_dataclasses()  # the outcomes go back pickled (a compiled build's too)
    return BatchResult(build_id(), socket.gethostname(), batch.robot_hash, outcomes)


def _worker_build() -> tuple[str, str]:
    return build_id(), socket.gethostname()


@contextmanager
def cluster_client(
    address: str, workers: int, wait_s: float = WORKERS_TIMEOUT_S
) -> Iterator[Client]:
    """A client of the cluster at `address` (`LOCAL`: a new cluster of `workers` processes on
    127.0.0.1, shut down on the way out, Ctrl-C included) that shows a worker within `wait_s`;
    every worker checked to run this build of bywire. The one place a cluster starts and
    stops."""
    try:
        import dask  # noqa: PLC0415 -- an optional extra, only with --cluster
        from distributed import Client, LocalCluster  # noqa: PLC0415

        from bywire.sim.verify.cluster_worker import LeaveInterruptToTheParent  # noqa: PLC0415
    except ImportError:
        raise ClusterError(INSTALL) from None
    settings = {
        "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
        "distributed.scheduler.worker-saturation": 1.0,  # no batch waits behind another
    }
    with dask.config.set(settings):
        cluster = None
        interrupted = _Deferred()
        if address == LOCAL:
            with interrupted:  # a Ctrl-C while it starts is taken once it can be shut down
                cluster = LocalCluster(  # type: ignore[no-untyped-call]
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=True,
                    host=LOOPBACK,
                    dashboard_address=None,
                    # its HTTP routes (health, metrics) on a free loopback port: by default
                    # 8787, and a second cluster found it taken and warned on the user's stderr
                    scheduler_kwargs={"dashboard": False, "dashboard_address": f"{LOOPBACK}:0"},
                    silence_logs=logging.ERROR,
                    # set up in each worker process before it joins, a replacement's too
                    plugins=(LeaveInterruptToTheParent(),),
                )
        try:
            interrupted.act()
            try:
                client = Client(  # type: ignore[no-untyped-call]
                    cluster if cluster is not None else address,
                    timeout="30s",
                    direct_to_workers=False,  # results through the scheduler: one tunnel
                )
            except (OSError, ValueError, TypeError) as error:
                raise ClusterError(f"cannot reach the cluster at {address}: {error}") from None
            try:
                _check_workers(client, address, wait_s)
                yield client
            finally:
                client.close()  # type: ignore[no-untyped-call]
        finally:
            if cluster is not None:
                cluster.close()


class _Deferred:
    """Holds a Ctrl-C (SIGINT) or a SIGTERM back while a local cluster starts: interrupted
    half-way, the cluster was left for distributed's exit hook, which failed on it with a
    traceback ("Status.init"). `act` then raises it again, once the cluster can be shut down,
    through the handler in force (`bywire verify` takes SIGTERM as it takes Ctrl-C). Outside the
    main thread, where no handler can be set, nothing is held."""

    HELD = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.pending: int | None = None
        self._previous: dict[int, object] = {}

    def _hold(self, signum: int, _frame: object) -> None:
        if self.pending is None:
            self.pending = signum

    def __enter__(self) -> None:
        if threading.current_thread() is threading.main_thread():
            for held in self.HELD:
                self._previous[held] = signal.signal(held, self._hold)

    def __exit__(self, *_exc: object) -> None:
        for held, previous in self._previous.items():
            signal.signal(held, previous)  # type: ignore[arg-type]

    def act(self) -> None:
        """The signal held, if any, raised now as it would have been."""
        if self.pending == signal.SIGINT:
            raise KeyboardInterrupt
        if self.pending is not None:
            signal.raise_signal(self.pending)


def _check_workers(client: Client, address: str, wait_s: float) -> None:
    try:
        client.wait_for_workers(1, timeout=wait_s)
    except TimeoutError:
        raise ClusterError(
            f"the cluster at {address} has no worker after {wait_s:g} s: start one"
            f" (dask worker {address} --nthreads 1) or give it longer (--workers-wait-s)"
        ) from None
    try:
        builds: dict[str, tuple[str, str]] = client.run(_worker_build)
    except Exception as error:  # a worker without bywire, or an older one
        raise ClusterError(f"a worker of {address} cannot run bywire: {error}") from None
    for worker, (build, host) in sorted(builds.items()):
        _check_build(build, f"{worker} on {host}")
    for worker, info in sorted(client.scheduler_info(n_workers=-1)["workers"].items()):
        if info["nthreads"] != 1:
            raise ClusterError(
                f"worker {worker} runs {info['nthreads']} threads: a campaign needs a process"
                " of its own; start workers with `dask worker --nthreads 1 --nworkers N`"
            )


def worker_deaths(client: Client) -> int | None:
    """How often a batch's worker dies before the scheduler gives up on it (KilledWorker)."""
    try:
        allowed: int = client.run_on_scheduler(  # type: ignore[no-untyped-call]
            lambda dask_scheduler: dask_scheduler.allowed_failures  # by value: no bywire there
        )
    except Exception:  # a scheduler that refuses pickled functions: it does not say
        return None
    return allowed + 1


def _check_build(build: str, where: str) -> None:
    if build != build_id():
        raise ClusterError(
            f"worker {where} runs bywire {build}, this machine {build_id()}: mixed versions"
            " are refused; install the same bywire on every worker"
        )


def worker_count(client: Client) -> int:
    return len(client.scheduler_info(n_workers=-1)["workers"])


def batch_size(budget: int | None, workers: int) -> int:
    """Campaigns a batch: enough batches to keep every worker busy twice over, at most
    BATCH_MAX."""
    if budget is None:
        return BATCH_MAX
    return max(1, min(BATCH_MAX, math.ceil(budget / (2 * max(1, workers)))))


def _checked(result: BatchResult, robot_file_hash: str) -> tuple[Outcome, ...]:
    """A batch's outcomes, when this build ran them on the robot file being verified."""
    _check_build(result.build, f"on {result.host}")
    if result.robot_hash != robot_file_hash:
        raise ClusterError(
            f"a worker on {result.host} answered for robot file {result.robot_hash},"
            f" not {robot_file_hash}: refused"
        )
    return result.outcomes


class _Dispatch:
    """The batches out on the cluster: at most `IN_FLIGHT_PER_WORKER` a worker, the halves of a
    killed batch before any new one."""

    def __init__(
        self, client: Client, batch: Batch, budget: int | None, until: float | None
    ) -> None:
        self.client = client
        self.template = batch  # job, robot and hash; its range is not used
        self.workers = worker_count(client)
        self.size = batch_size(budget, self.workers)
        self.stop = budget
        self.until = until
        self.next_start = 0
        self.retry: list[tuple[int, int]] = []
        self.out: dict[Future[BatchResult], Batch] = {}

    def _submit(self, start: int, end: int) -> None:
        batch = replace(self.template, start=start, stop=end)
        stamp = time.monotonic_ns()
        key = f"bywire-verify-{batch.robot_hash}-{batch.job.seed}-{start}-{end}-{stamp}"
        future = self.client.submit(run_batch, batch, key=key, pure=False)
        self.out[future] = batch

    def fill(self) -> None:
        while len(self.out) < IN_FLIGHT_PER_WORKER * max(1, self.workers):
            if self.retry:  # through the same gate: two halves on one worker share a death
                self._submit(*self.retry.pop(0))
                continue
            if self.stop is not None and self.next_start >= self.stop:
                return
            if self.stop is None and self.until is not None and time.monotonic() >= self.until:
                return
            end = self.next_start + self.size
            if self.stop is not None:
                end = min(self.stop, end)
            self._submit(self.next_start, end)
            self.next_start = end

    def completed(
        self, no_worker_limit_s: float, clock: Callable[[], float]
    ) -> Iterator[Future[BatchResult]]:
        """The batches out, each as it finishes (the caller takes it out of `out` and may give
        out more); `ClusterLostError` when no worker has been there for `no_worker_limit_s`."""
        alone_since: float | None = None
        while self.out:
            done = _first_done(list(self.out))
            settled = [future for future in done if future.status in SETTLED]
            if settled:
                alone_since = None
                yield from (future for future in settled if future in self.out)
                continue
            if done:  # only results lost with their worker: computed again, if a worker is left
                time.sleep(WAIT_S)
            if worker_count(self.client) > 0:
                alone_since = None
            elif alone_since is None:
                alone_since = clock()
            elif clock() - alone_since >= no_worker_limit_s:
                address = self.client.scheduler.address if self.client.scheduler else "?"
                first = min(batch.start for batch in self.out.values())
                raise ClusterLostError(
                    f"the cluster at {address} has had no worker for {no_worker_limit_s:g} s,"
                    f" so campaigns {first} onwards cannot run: start its workers again"
                    f" (dask worker {address} --nthreads 1) and run again, or run without"
                    " --cluster"
                )

    def split(self, batch: Batch) -> bool:
        """Run a killed batch again as two halves; False for a single campaign."""
        if batch.stop - batch.start <= 1:
            return False
        middle = (batch.start + batch.stop) // 2
        self.retry[:0] = [(batch.start, middle), (middle, batch.stop)]
        return True

    def cancel(self) -> None:
        for future in self.out:
            future.cancel()  # type: ignore[no-untyped-call]


def _first_done(futures: list[Future[BatchResult]]) -> list[Future[BatchResult]]:
    """Those of `futures` done once the first is, or none after `WAIT_S`."""
    from distributed import wait  # noqa: PLC0415 -- an optional extra

    try:
        waited = wait(futures, timeout=WAIT_S, return_when="FIRST_COMPLETED")  # type: ignore[no-untyped-call]
    except TimeoutError:
        return []
    return list(waited.done)


def cluster_outcomes(
    client: Client,
    *,
    robot: RobotConfig,
    robot_file_hash: str,
    job: CampaignJob,
    budget: int | None,
    until: float | None,
    no_worker_limit_s: float = WORKERS_TIMEOUT_S,
    clock: Callable[[], float] = time.monotonic,
) -> Generator[Outcome | Crash, None, None]:
    """Every campaign's outcome (or its crash) in index order: `budget` of them, or as many
    batches as start before the wall-clock time `until`. `ClusterLostError` once the cluster has had
    no worker for `no_worker_limit_s` of `clock` (the outcomes before it already yielded)."""
    from distributed.client import FutureCancelledError as CancelledError  # noqa: PLC0415
    from distributed.scheduler import KilledWorker  # noqa: PLC0415 -- an optional extra

    picklable_compiled_dataclasses()  # the batches go out pickled (a compiled build's too)
    deaths = worker_deaths(client)
    dispatch = _Dispatch(client, Batch(job, robot, robot_file_hash, 0, 0), budget, until)
    ready: dict[int, Outcome | Crash] = {}
    released = 0
    dispatch.fill()
    try:
        for future in dispatch.completed(no_worker_limit_s, clock):
            batch = dispatch.out.pop(future)
            try:
                result: BatchResult = future.result(timeout=RESULT_WAIT_S)
            except TimeoutError:  # lost with its worker since it was seen settled: wait again
                dispatch.out[future] = batch
                continue
            except KilledWorker:
                if not dispatch.split(batch):
                    ready[batch.start] = Crash(job.seed, batch.start, deaths)
            except CancelledError as cancelled:  # the scheduler went, or cancelled it
                raise ClusterLostError(
                    f"the cluster cancelled campaigns {batch.start} onwards ({cancelled}):"
                    " check its scheduler, and run again"
                ) from None
            else:
                ready.update((o.index, o) for o in _checked(result, robot_file_hash))
            # Let go at once: a result still held when its worker dies is computed again,
            # beside the next batch, and that batch's crash would count against it too.
            future.release()  # type: ignore[no-untyped-call]
            dispatch.fill()
            while released in ready:
                yield ready.pop(released)
                released += 1
    finally:
        dispatch.cancel()
    yield from (ready[index] for index in sorted(ready))
