"""Freshness values that survive restarts: reserved ahead on disk in blocks, never reused.

Per data id (CAN id) the store keeps a *bound*: no value above it was ever sent (sender) or
accepted (receiver). A value is used only once the bound on disk covers it (write-ahead): when
a value reaches the durable bound's last half block, a background thread writes the bound one
block further (temporary file, fsync, rename: a crash leaves the old file or the new one); only
if that write has not landed when the value passes the bound is it written in line. After a
restart the bound on disk is where the sender resumes (one above it) and the receiver's floor
(it accepts only above it): a crash loses at most a block of unused values, never reuses one.

The file also names the key it belongs to by its check value: a new key starts every id at 0
(frames made with the old key fail their MAC anyway). A missing file starts at 0 too; the
caller says so (losing the file with an old key opens a replay window: make a new key, see
docs/SECURITY.md).
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
import threading
from pathlib import Path

from bywire.errors import ConfigError
from bywire.priority import leave_realtime
from bywire.protocol.secoc import SecocKey

DEFAULT_BLOCK = 32
FILE_MODE = 0o600


class FreshnessStore:
    """The per-id bounds of one end (sender or receiver); in memory when `path` is None."""

    def __init__(self, key: SecocKey, path: Path | None = None, block: int = DEFAULT_BLOCK) -> None:
        if block < 2:
            raise ValueError(f"freshness block {block}: at least 2")
        self.path = path
        self.block = block
        self._key_check = key.check_value
        self.found = False
        """A file for this key was there at start (False: every id starts at 0)."""
        self._durable = self._load(path) if path is not None else {}
        self.start_bounds = dict(self._durable)
        self._wanted = dict(self._durable)
        self._lock = threading.Lock()
        self._write_lock = threading.Lock()
        self._pending = threading.Event()
        self._closed = False
        self._writer: threading.Thread | None = None

    def bound(self, data_id: int) -> int:
        """The bound loaded at start: every value up to it may have been used before."""
        return self.start_bounds.get(data_id, 0)

    def reserve(self, data_id: int, value: int) -> None:
        """Make sure `value` is covered on disk before it is sent or accepted; OSError when
        the file cannot be written (the value must then not be used)."""
        if self.path is None:
            return
        durable = self._durable.get(data_id, 0)
        if value > durable:  # the background write fell behind, or the first use: in line
            with self._lock:
                self._wanted[data_id] = max(self._wanted.get(data_id, 0), value + self.block)
            self._flush()
        elif durable - value < self.block // 2 and self._wanted.get(data_id, 0) <= durable:
            with self._lock:
                self._wanted[data_id] = durable + self.block
            self._wake_writer()

    def save(self) -> None:
        """Write the bounds as they are (at start-up: the file exists and can be written)."""
        with self._write_lock:
            if self.path is not None:
                _write_atomically(self.path, self._key_check, dict(self._durable))

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
        self._flush()

    # --- the file -----------------------------------------------------------------------------

    def _load(self, path: Path) -> dict[int, int]:
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return {}
        except OSError as error:
            raise ConfigError(f"{path}: cannot read freshness file: {error}") from None
        try:
            document = json.loads(text)
            bounds = {int(k): int(v) for k, v in document["bounds"].items()}
            key_check = str(document["key_check"])
        except (ValueError, KeyError, TypeError, AttributeError):
            raise ConfigError(
                f"{path}: not a bywire freshness file (docs/SECURITY.md: resynchronising)"
            ) from None
        if key_check != self._key_check:
            return {}  # a new key: its values start afresh
        self.found = True
        return bounds

    def _flush(self) -> None:
        with self._write_lock:
            path = self.path
            with self._lock:
                snapshot = dict(self._wanted)
            if path is None or snapshot == self._durable:
                return
            _write_atomically(path, self._key_check, snapshot)
            self._durable = snapshot

    def _wake_writer(self) -> None:
        if self._writer is None and not self._closed:
            self._writer = threading.Thread(target=self._write_loop, name="freshness", daemon=True)
            self._writer.start()
        self._pending.set()

    def _write_loop(self) -> None:
        leave_realtime()  # persisting counters never competes with the loop at its priority
        while not self._closed:
            self._pending.wait()
            self._pending.clear()
            with contextlib.suppress(OSError):  # the in-line write that follows will say why
                self._flush()


def _write_atomically(path: Path, key_check: str, bounds: dict[int, int]) -> None:
    document = {"key_check": key_check, "bounds": {str(k): v for k, v in sorted(bounds.items())}}
    descriptor, temporary = tempfile.mkstemp(prefix=path.name + ".", dir=path.parent)
    os.fchmod(descriptor, FILE_MODE)
    with os.fdopen(descriptor, "w", encoding="utf-8") as file:
        file.write(json.dumps(document) + "\n")
        file.flush()
        os.fsync(file.fileno())
    os.replace(temporary, path)
    with contextlib.suppress(OSError):  # make the rename itself durable where the OS allows
        directory = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(directory)
        finally:
            os.close(directory)
