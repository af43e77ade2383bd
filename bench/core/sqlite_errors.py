"""SQLite's errors on the store as the ``OSError`` the machine gave, reported in one line: a
full disk or the file size limit, a read-only folder, a lock held past the timeout."""

from __future__ import annotations

import errno
import os
import sqlite3
from pathlib import Path

LOCK_TIMEOUT_S = 600.0
"""How long a writer waits for another writer's lock on the store, seconds."""


def os_error(error: sqlite3.Error, path: Path) -> OSError:
    """SQLite's error on ``path`` as the ``OSError`` the machine gave (reported in one line):
    a full disk or the file size limit, a read-only folder, a lock held past the timeout."""
    primary = getattr(error, "sqlite_errorcode", -1) & 0xFF
    code = {
        sqlite3.SQLITE_FULL: errno.ENOSPC,
        sqlite3.SQLITE_IOERR: errno.EIO,
        sqlite3.SQLITE_READONLY: errno.EROFS,
        sqlite3.SQLITE_CANTOPEN: errno.EACCES,
        sqlite3.SQLITE_PERM: errno.EACCES,
        sqlite3.SQLITE_BUSY: errno.EBUSY,
    }.get(primary)
    if code is None:
        raise error
    limit = _file_size_limit()
    if code in (errno.ENOSPC, errno.EIO) and limit is not None:
        code = errno.EFBIG  # most likely: a write past the limit fails as a full disk or EIO
        return OSError(
            code,
            f"File too large: the file size limit (ulimit -f) is {limit} bytes (SQLite: {error})",
            str(path),
        )
    reason = {
        errno.ENOSPC: "No space left on device or the file size limit reached",
        errno.EBUSY: f"the store stayed locked by another writer for {LOCK_TIMEOUT_S:.0f} s",
        errno.EIO: "Input/output error (a full disk, the file size limit or a failing disk)",
    }.get(code, os.strerror(code))
    return OSError(code, f"{reason} (SQLite: {error})", str(path))


def _file_size_limit() -> int | None:
    """This process's file size limit in bytes (``ulimit -f``), None if there is none."""
    try:
        import resource
    except ImportError:  # not on Windows
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    return None if soft == resource.RLIM_INFINITY else soft
