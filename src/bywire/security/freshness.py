"""A sender's freshness: the controller's trip counter it signs with, and its message counters in
that trip, reserved ahead on disk in blocks so that a restarted sender never reuses one.

The freshness value is trip counter << 32 | message counter (`bywire.protocol.secoc`). The trip
is the controller's, taken from its authenticated announcement (`adopt`); in a new trip every
message counter starts again at 1. A lower trip than the one in the file is refused: either an
old announcement replayed, or a controller whose freshness file was rolled back.

Per data id (CAN id) the store keeps a *bound*: no counter above it was ever sent in this trip. A
value is used only once the bound on disk covers it (write-ahead): when a value reaches the
durable bound's last half block, a background thread writes the bound one block further; only if
that write has not landed when the value passes the bound is it written in line (`OSError` then:
the value must not be used). After a restart in the same trip the sender resumes one above its
bound. The file is this sender's only: its loss costs liveness (the controller, which accepted
higher counters in this trip, rejects the lower ones until its next start), never safety.
"""

from __future__ import annotations

import contextlib
import enum
import threading
from pathlib import Path

from bywire.background import OWNER
from bywire.errors import ConfigError
from bywire.priority import leave_realtime
from bywire.protocol.secoc import MAX_COUNTER, MAX_TRIP, SecocKey
from bywire.security.state_file import Problem, StateFileError, read_state, whole, write_state

DEFAULT_BLOCK = 32
KIND = "bywire sender freshness 1"
WHAT = "sender's freshness file"
MAX_DATA_ID = 0x7FF


class Adoption(enum.Enum):
    """What an announced trip counter means to this sender."""

    SAME = "the trip this sender signs in: its counters go on"
    NEW = "a new trip: every counter starts again at 1"
    LOWER = "below the trip this sender used: refused (a replayed announcement, or a rollback)"


class FreshnessStore:
    """A sender's trip and per-id bounds; in memory when `path` is None.

    ConfigError at construction for a file that is damaged, another key's or out of range (a
    missing one is a first start)."""

    def __init__(self, key: SecocKey, path: Path | None = None, block: int = DEFAULT_BLOCK) -> None:
        if block < 2:
            raise ValueError(f"freshness block {block}: at least 2")
        self.path = path
        self.block = block
        self._key = key
        self.trip, durable = self._load(path) if path is not None else (0, {})
        """The trip counter the bounds belong to (0: none yet)."""
        self._durable = durable
        self.start_bounds = dict(durable)
        self._wanted = dict(durable)
        self._lock = threading.Lock()
        self._write_lock = threading.Lock()
        self._pending = threading.Event()
        self._closed = False
        self._writer: threading.Thread | None = None

    def adopt(self, trip: int) -> Adoption:
        """Take the controller's announced trip counter (verified by the caller). A new trip is
        on the disk before this returns (OSError otherwise, and it is not taken)."""
        if trip < self.trip:
            return Adoption.LOWER
        if trip == self.trip:
            return Adoption.SAME
        with self._write_lock:
            if self.path is not None:
                write_state(self.path, self._key, KIND, _fields(trip, {}))
            with self._lock:
                self.trip, self._durable, self._wanted, self.start_bounds = trip, {}, {}, {}
        return Adoption.NEW

    def bound(self, data_id: int) -> int:
        """The bound at the start of this trip (or of this process): every counter up to it may
        have been used before."""
        return self.start_bounds.get(data_id, 0)

    def reserve(self, data_id: int, value: int) -> None:
        """Make sure counter `value` is covered on disk before it is sent; OSError when the file
        cannot be written (the value must then not be used)."""
        if self.path is None:
            return
        durable = self._durable.get(data_id, 0)
        if value > durable:  # the background write fell behind, or the first use: in line
            with self._lock:
                wanted = min(max(self._wanted.get(data_id, 0), value + self.block), MAX_COUNTER)
                self._wanted[data_id] = wanted
            self._flush()
        elif durable - value < self.block // 2 and self._wanted.get(data_id, 0) <= durable:
            with self._lock:
                self._wanted[data_id] = min(durable + self.block, MAX_COUNTER)
            self._wake_writer()

    def halt(self) -> None:
        """Stop writing at once, pending writes lost, as a killed process does (restart tests)."""
        with self._write_lock:  # a write under way finishes: a rename is atomic either way
            self.path = None
        self._closed = True
        self._pending.set()

    def close(self) -> None:
        """Write what is pending and stop the writer thread."""
        self._closed = True
        self._pending.set()
        if self._writer is not None:
            self._writer.join()
        with contextlib.suppress(OSError):  # nothing is lost: what was used is on disk
            self._flush()

    # --- the file -----------------------------------------------------------------------------

    def _load(self, path: Path) -> tuple[int, dict[int, int]]:
        try:
            fields = read_state(path, self._key, KIND, WHAT)
        except StateFileError as error:
            if error.problem is Problem.MISSING:
                return 0, {}
            raise ConfigError(
                f"{error}: move it away to start this sender afresh (the robot then accepts"
                " it after its next restart)"
            ) from None
        trip = whole(fields.get("trip"), 0, MAX_TRIP)
        counters = fields.get("counters")
        bounds = _bounds(counters) if isinstance(counters, dict) else None
        if set(fields) != {"trip", "counters"} or trip is None or bounds is None:
            raise ConfigError(
                f"{path}: {WHAT} has a field out of range (trip 0..{MAX_TRIP}, counters"
                f" 0..{MAX_COUNTER} by CAN id 0..{MAX_DATA_ID}): move it away to start afresh"
            )
        return trip, bounds

    def _flush(self) -> None:
        with self._write_lock:
            path = self.path
            with self._lock:
                snapshot, trip = dict(self._wanted), self.trip
            if path is None or snapshot == self._durable:
                return
            write_state(path, self._key, KIND, _fields(trip, snapshot))
            self._durable = snapshot

    def _wake_writer(self) -> None:
        if self._writer is None and not self._closed:
            self._writer = OWNER.thread(
                self._write_loop, name="bywire-freshness-writer", stop=self.close
            )
        self._pending.set()

    def _write_loop(self) -> None:
        leave_realtime()  # persisting counters never competes with the sending at its priority
        while not self._closed:
            self._pending.wait()
            self._pending.clear()
            with contextlib.suppress(OSError):  # the in-line write that follows will say why
                self._flush()


def _fields(trip: int, bounds: dict[int, int]) -> dict[str, object]:
    return {"trip": trip, "counters": {str(k): v for k, v in sorted(bounds.items())}}


def _bounds(counters: dict[str, object]) -> dict[int, int] | None:
    bounds: dict[int, int] = {}
    for name, value in counters.items():
        data_id = whole(int(name), 0, MAX_DATA_ID) if name.isdecimal() and len(name) < 5 else None
        bound = whole(value, 0, MAX_COUNTER)
        if data_id is None or bound is None:
            return None
        bounds[data_id] = bound
    return bounds
