"""The MCAP file under foxglove-sdk's writer: space kept ahead, and a failure that never floods.

foxglove-sdk writes the MCAP through this file object. Space for `reserve_bytes` beyond the end
of the data is allocated to the file ahead of the data (`fallocate` with FALLOC_FL_KEEP_SIZE: the
blocks are the file's, its size does not change). When that allocation fails for want of space,
`full` is set while the reserve still holds the chunk being written and the summary: the writer
then closes the recording there, and the file is a complete, indexed MCAP up to that point.

Any write that fails anyway (an I/O error, a read-only remount, a reserve used up) sets `error`
and every later write is dropped, reported as written: the SDK never sees a failure, so it never
logs one per message (which flooded the journal at 430 lines a second). On a filesystem that
cannot allocate ahead (FAT) there is no reserve, and a full disk is such an error.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
from pathlib import Path

FALLOC_FL_KEEP_SIZE = 1
CHUNK_BYTES = 1 << 20  # foxglove-sdk's chunk size (uncompressed)
RESERVE_BYTES = 4 * CHUNK_BYTES  # a chunk that does not compress, its indexes, the summary
STEP_BYTES = 4 << 20  # allocated in steps: one call per few MiB written
_LIBC = ctypes.CDLL(None, use_errno=True)


class McapFile:
    """A binary file for foxglove-sdk's MCAP writer (`write`, `seek`, `tell`, `flush`)."""

    def __init__(self, path: Path, reserve_bytes: int = RESERVE_BYTES) -> None:
        self.path = path
        self._reserve_bytes = reserve_bytes
        self._fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o644)
        self._allocated = 0
        self._position = 0  # the SDK's view: it checks that the file is where it wrote up to
        self._length = 0
        self._end = 0  # the data on the disk
        self.full = False
        """No more space could be allocated ahead: close the recording now, the reserve holds it."""
        self.error: OSError | None = None
        """A write failed: nothing more is written."""
        self.dropped_bytes = 0
        self._allocate(0)

    def write(self, data: bytes | bytearray) -> int:
        position = self._position
        self._position += len(data)  # where the SDK counts on being, written or not
        self._length = max(self._length, self._position)
        if self.error is not None:
            self.dropped_bytes += len(data)
            return len(data)
        try:
            self._allocate(position + len(data))
            view = memoryview(data)
            while view:
                written = os.pwrite(self._fd, view, position)
                view, position = view[written:], position + written
        except OSError as error:
            self.error = error
            self.dropped_bytes += len(data)
        self._end = max(self._end, position)
        return len(data)

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self._position, os.SEEK_END: self._length}[whence]
        self._position = base + offset
        return self._position

    def tell(self) -> int:
        return self._position

    def flush(self) -> None:
        """Nothing to flush: every write went to the file (no buffer in this process)."""

    def close(self) -> None:
        """Give back the space allocated past the data, and close."""
        if self._fd < 0:
            return
        with contextlib.suppress(OSError):
            os.ftruncate(self._fd, self._end)
        os.close(self._fd)
        self._fd = -1

    def _allocate(self, data_end: int) -> None:
        """Keep `reserve_bytes` allocated past `data_end`; on ENOSPC set `full` (the reserve
        already allocated is still the file's); where the filesystem cannot, go without."""
        if self.full or data_end + self._reserve_bytes <= self._allocated:
            return
        length = data_end + self._reserve_bytes + STEP_BYTES
        result = _LIBC.fallocate(
            self._fd, FALLOC_FL_KEEP_SIZE, ctypes.c_longlong(0), ctypes.c_longlong(length)
        )
        if result == 0:
            self._allocated = length
            return
        code = ctypes.get_errno()
        if code in (errno.ENOSPC, errno.EDQUOT):
            self.full = True
        elif code in (errno.EOPNOTSUPP, errno.ENOSYS, errno.EINVAL):
            self._allocated = 1 << 62  # no reserve here: a full disk is a write error
        else:
            raise OSError(code, os.strerror(code), str(self.path))
