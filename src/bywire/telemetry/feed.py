"""One telemetry feed for a run: the loop's tap, the outbox, the writer and its sinks, together.

`open_feed` is what a command uses: it attaches to a `Runtime` before the run, and on leaving
writes what is queued and closes the file and the server, whatever ended the run. On real time the
writer is a process of its own (`writer_process`), on virtual time a thread (`writer`).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from bywire.errors import ConfigError
from bywire.loopback import Endpoint, ListenAddress
from bywire.priority import outside_realtime
from bywire.runtime.loop import Runtime
from bywire.telemetry.capture import DEFAULT_RATE_HZ, Capture, TelemetryTap
from bywire.telemetry.outbox import DEFAULT_CAPACITY, Outbox
from bywire.telemetry.writer_process import WriterProcess

if TYPE_CHECKING:
    from bywire.telemetry.writer import TelemetryWriter

    Writer = TelemetryWriter | WriterProcess


@dataclass(frozen=True, slots=True)
class FeedOptions:
    """Where the feed goes and how often the state is sampled."""

    mcap_path: Path | None = None
    foxglove: Endpoint | ListenAddress | None = None
    rate_hz: float = DEFAULT_RATE_HZ
    capacity: int = DEFAULT_CAPACITY
    origins: tuple[str, ...] = ()
    """Web page origins the Foxglove server lets in (none: only clients that are no page)."""

    @property
    def wanted(self) -> bool:
        return self.mcap_path is not None or self.foxglove is not None


@dataclass(frozen=True, slots=True)
class TelemetryFeed:
    """A running feed: `tap` for the loop (and bus monitors), `port` the server listens on."""

    tap: TelemetryTap
    outbox: Outbox[Capture]
    writer: Writer
    port: int | None


def check_mcap_path(path: Path) -> None:
    """ConfigError unless `path` ends in .mcap and its folder exists (checked before a run)."""
    if path.suffix.lower() != ".mcap":
        raise ConfigError(f"cannot record to {path.name!r}: an MCAP file's name ends in .mcap")
    if not path.parent.is_dir():
        raise ConfigError(f"cannot write {path}: folder {path.parent} does not exist")


def new_outbox(options: FeedOptions, *, virtual_time: bool) -> Outbox[Capture]:
    """The feed's queue: on virtual time it waits for room, on real time it drops the oldest."""
    return Outbox(options.capacity, wait_when_full=virtual_time)


@dataclass(frozen=True, slots=True)
class FeedSinks:
    """The writer and its sinks, running before any tap feeds them: `port` the server's."""

    outbox: Outbox[Capture]
    writer: Writer
    port: int | None

    def tap(self, runtime: Runtime, *, rate_hz: float = DEFAULT_RATE_HZ) -> TelemetryTap:
        """The loop's tap into this feed (not yet attached); it ships to a writer process."""
        ship = self.writer.ship if isinstance(self.writer, WriterProcess) else None
        return TelemetryTap(runtime, self.outbox, rate_hz=rate_hz, ship=ship)


class Clock(Protocol):
    def now(self) -> float: ...


@contextlib.contextmanager
def open_sinks(
    options: FeedOptions,
    clock: Clock,
    *,
    virtual_time: bool,
    outbox: Outbox[Capture] | None = None,
    close_timeout_s: float = 5.0,
) -> Iterator[FeedSinks]:
    """The MCAP file, the server and the writer, for the duration of the block: on real time a
    process of its own (`WriterProcess`), on virtual time a thread of this one.

    Started before the controller is built (`bywire run`): the server's start takes tens of ms,
    which the loop's first deadlines must not wait for. `clock` is the controller's clock (the
    log times are its times). Log times are wall-clock (epoch) times: on virtual time the run's
    wall-clock start plus the simulated seconds, and the outbox waits for room rather than drop
    (no loop time exists to protect there); on real time a full outbox drops its oldest capture.
    `outbox`: one made beforehand with `new_outbox` (a `TappedCanPort` built with the hardware
    already queues into it). `close_timeout_s` bounds how long the end waits for the writer to
    encode what is queued (a writer process still finishing its file is left to finish it).
    """
    queue = new_outbox(options, virtual_time=virtual_time) if outbox is None else outbox
    if not virtual_time:
        offset_s = time.time() - clock.now()
        # Spawned outside the loop's real-time priority: the child and its threads inherit it.
        process = outside_realtime(
            lambda: WriterProcess(
                queue,
                mcap_path=options.mcap_path,
                foxglove=options.foxglove,
                log_offset_s=offset_s,
                origins=options.origins,
            )
        )
        try:
            yield FeedSinks(queue, process, process.port)
        finally:
            process.close(close_timeout_s)
        return
    # Imported here: on real time the writer (and foxglove's 39 MB native core) lives in the
    # writer process, never in the controller's.
    from bywire.telemetry.writer import TelemetryWriter  # noqa: PLC0415

    # Log times start at the wall-clock time of the run and keep the simulated offsets (a file
    # stamped from 1970 lands at the far left of Foxglove's timeline).
    writer = TelemetryWriter(queue, log_offset_s=time.time() - clock.now())
    try:
        yield FeedSinks(queue, writer, _start(writer, options))
    finally:
        writer.close(close_timeout_s)


def _start(writer: TelemetryWriter, options: FeedOptions) -> int | None:
    """Open the sinks and start the writer's thread; the server's port, if it serves."""
    if options.mcap_path is not None:
        writer.record(options.mcap_path)
    port = None if options.foxglove is None else writer.serve(options.foxglove, options.origins)
    writer.start()
    return port


@contextlib.contextmanager
def open_feed(
    runtime: Runtime,
    options: FeedOptions,
    *,
    virtual_time: bool,
    outbox: Outbox[Capture] | None = None,
    close_timeout_s: float = 5.0,
) -> Iterator[TelemetryFeed]:
    """Attach a feed to `runtime` for the duration of the block (`open_sinks`, then the tap)."""
    with open_sinks(
        options,
        runtime.clock,
        virtual_time=virtual_time,
        outbox=outbox,
        close_timeout_s=close_timeout_s,
    ) as sinks:
        tap = sinks.tap(runtime, rate_hz=options.rate_hz).attach()
        try:
            yield TelemetryFeed(tap, sinks.outbox, sinks.writer, sinks.port)
        finally:
            tap.detach()
