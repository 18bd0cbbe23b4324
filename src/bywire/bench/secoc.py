"""What authenticated commands cost the controller: the CAN reader's time per command with and
without SecOC verification, on the same traffic, interleaved so both see the same machine.

Each sample is one `CanReader.poll` that takes one MovementCommand (plain: the frame; with
authentication: the frame and its cryptographic PDU, paired, CMAC checked, freshness reserved
in memory); the two readers never see the same payload, so the codec's cache helps neither.
The cost at p99 is p99(authenticated) - p99(plain) of the thread's CPU time per poll: what the
loop's latency grows by when nothing preempts it, as on the robot under SCHED_FIFO. The same in
wall-clock time is given too; on a shared machine it also measures how often the process is
preempted (a poll that takes 1.5x longer is 1.5x as likely to be interrupted), not the reader.
The second frame's time on the wire (one 8-byte frame at the bus bitrate) is the other part of
the price, computed, not measured.
"""

from __future__ import annotations

import gc
import time
from dataclasses import dataclass

from bywire.bench.stats import LatencySummary, summarise
from bywire.can_frame import CanFrame
from bywire.hal.ports import LINK_UP, LinkState
from bywire.model import Gear, MovementCommand
from bywire.protocol import dbc
from bywire.protocol.bittiming import frame_bits
from bywire.protocol.secoc import AUTH_PDU_BYTES, SecocKey
from bywire.runtime.readers import CanReader
from bywire.security.freshness import FreshnessStore
from bywire.security.session import SecocReceiver, SecocSigner
from bywire.security.trip import IN_MEMORY_TRIP

DEFAULT_SAMPLES = 20_000
BENCH_SECRET = bytes(range(16))  # made a key only when measuring: keys load cryptography


class _Inbox:
    """A CanPort holding the frames of the next poll (the reader's input, nothing else)."""

    def __init__(self) -> None:
        self.frames: list[CanFrame] = []

    def send(self, frame: CanFrame) -> bool:
        return True

    def receive(self) -> list[CanFrame]:
        frames, self.frames = self.frames, []
        return frames

    @property
    def link(self) -> LinkState:
        return LINK_UP


@dataclass(frozen=True, slots=True)
class SecocCost:
    """Per-command reader time (CPU and wall clock), plain and authenticated, and the second
    frame's time on the wire."""

    plain: LatencySummary
    authenticated: LatencySummary
    plain_wall: LatencySummary
    authenticated_wall: LatencySummary
    wire_s: float

    @property
    def p99_cost_s(self) -> float | None:
        """The CPU time verification adds at p99."""
        return _p99_difference(self.plain, self.authenticated)

    @property
    def p99_wall_cost_s(self) -> float | None:
        """The same in wall-clock time (preemption included)."""
        return _p99_difference(self.plain_wall, self.authenticated_wall)


def _p99_difference(plain: LatencySummary, authenticated: LatencySummary) -> float | None:
    if plain.p99_s is None or authenticated.p99_s is None:
        return None
    return authenticated.p99_s - plain.p99_s


def measure_secoc_cost(samples: int = DEFAULT_SAMPLES, bitrate_bps: int = 500_000) -> SecocCost:
    """Time `samples` polls of each kind, alternating.

    The objects that exist before are frozen out of the collector, as `Runtime.run` freezes
    everything start-up built: otherwise a full collection of whatever the process made before
    (the bench's earlier phases) lands on 1 % of the samples and measures that heap, not the
    reader.
    """
    gc.collect()
    gc.freeze()
    try:
        return _measure(samples, bitrate_bps)
    finally:
        gc.unfreeze()


def _measure(samples: int, bitrate_bps: int) -> SecocCost:
    plain_port, secure_port = _Inbox(), _Inbox()
    plain = CanReader(plain_port)
    key = SecocKey(BENCH_SECRET)
    receiver = SecocReceiver(key, IN_MEMORY_TRIP, dbc.command_ids())
    secure = CanReader(secure_port, secoc=receiver)
    signer = SecocSigner(key, FreshnessStore(key))
    for frame_id, data in receiver.announcement:  # the controller's trip counter, heard
        signer.hear(frame_id, data)
    plain_s: list[tuple[float, float]] = []
    secure_s: list[tuple[float, float]] = []
    for index in range(samples):
        now = index * 0.02
        plain_port.frames = [CanFrame(*_movement(2 * index, index % 16))]
        plain_s.append(_timed(plain, now))
        frame_id, payload = _movement(2 * index + 1, index % 16)
        authenticator = signer.authenticator(frame_id, payload)
        if authenticator is None:
            raise RuntimeError("the bench's signer cannot sign")
        secure_port.frames = [CanFrame(frame_id, payload), authenticator]
        secure_s.append(_timed(secure, now))
    if secure.auth_failures or len(plain_s) != samples:
        raise RuntimeError(f"authentication failed in the bench: {dict(secure.auth_failures)}")
    wire_s = frame_bits(AUTH_PDU_BYTES) / bitrate_bps
    return SecocCost(
        plain=summarise([cpu for cpu, _ in plain_s]),
        authenticated=summarise([cpu for cpu, _ in secure_s]),
        plain_wall=summarise([wall for _, wall in plain_s]),
        authenticated_wall=summarise([wall for _, wall in secure_s]),
        wire_s=wire_s,
    )


def _movement(step: int, counter: int) -> tuple[int, bytes]:
    """A movement frame whose throttle differs from the last few thousand (no cache hits)."""
    throttle_norm = (step % 10_000) / 10_000
    return dbc.encode_command(MovementCommand(0.0, throttle_norm, 0.0, Gear.FORWARD, counter))


def _timed(reader: CanReader, now: float) -> tuple[float, float]:
    """The poll's CPU time and wall-clock time, in seconds."""
    started_cpu, started = time.thread_time_ns(), time.perf_counter_ns()
    accepted = reader.poll(now)
    wall_ns, cpu_ns = time.perf_counter_ns() - started, time.thread_time_ns() - started_cpu
    if len(accepted) != 1:
        raise RuntimeError("the bench's command was not accepted")
    return cpu_ns / 1e9, wall_ns / 1e9
